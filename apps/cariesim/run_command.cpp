// `cariesim run` (and `cariesim` with no subcommand), docs/design.md §5-6: the simulator window on a
// scene with a device, the servo loop on its own thread, optionally a session record; for automation
// a screenshot after some seconds of servo time. docs/viewer.md describes the window.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cariesim/servo/servo.hpp"
#include "commands.hpp"
#ifdef CARIESIM_HAS_VIEWER
#include "viewer/viewer.hpp"
#endif

namespace cariesim::cli {

namespace {

// Exit status when there is no display to open the window on.
constexpr int kNoDisplay = 4;

// The window's options that `run` and `review` share.
struct WindowArgs {
  std::string screenshot;
  double exit_after = 0.0;           // s of servo time
  std::vector<int> size{1280, 800};  // px, the window's width and height
  std::string view;                  // camera preset; empty: the whole scene framed
  bool no_realtime = false;
};

// Adds WindowArgs' options to `sub`; `exit_help` says whose servo time --exit-after counts.
void add_window_options(CLI::App* sub, WindowArgs& w, const std::string& exit_help) {
  auto* exit_after = sub->add_option("--exit-after", w.exit_after, exit_help)->check(finite_range(1e-6, 1e9));
  sub->add_option("--screenshot", w.screenshot,
                  "Write the last frame as PNG (and a status FILE.json beside it) when exiting")
      ->needs(exit_after);
  sub->add_option("--size", w.size, "Window width and height in pixels (the window can be resized)")
      ->expected(2)
      ->check(CLI::Range(320, 8192))
      ->capture_default_str();
  sub->add_option("--view", w.view,
                  "Camera preset on the explorer's tip: occlusal | buccal | lingual | operator (keys F1-F4)")
      ->check(CLI::IsMember({"occlusal", "buccal", "lingual", "operator"}));
  sub->add_flag("--no-realtime", w.no_realtime, "Do not ask for real-time priority for the servo thread");
}

#ifdef CARIESIM_HAS_VIEWER
// The viewer's window with `options` and the shared window options, or kNoDisplay (and how to use Xvfb
// instead) without a display.
int open_window(const WindowArgs& w, viewer::ViewerOptions options) {
  if (!viewer::display_available()) {
    std::fputs(("error: " + viewer::headless_message()).c_str(), stderr);
    return kNoDisplay;
  }
  options.screenshot = w.screenshot;
  options.exit_after = w.exit_after;
  options.width = w.size[0];
  options.height = w.size[1];
  options.view = w.view;
  options.realtime = !w.no_realtime;
  return viewer::run_viewer(options);
}
#else
int without_viewer() {
  std::fputs("error: this cariesim was built without the viewer (CARIESIM_BUILD_VIEWER=OFF)\n", stderr);
  return 3;
}
#endif

struct RunArgs {
  std::string scene = "real-arch";
  std::string device = "mouse";
  std::string device_profile;  // a hardware device's profile file
  double rate = 0.0;  // Hz; 0 = the scene's servo rate
  std::string record;
  bool overwrite = false;
  WindowArgs window;
  bool show_lesions = false;
  double spin_us = kDefaultSpinUs;  // µs polled before each deadline
  bool no_standby = false;          // no standby servo thread (ServoOptions::standby)
  bool trainee = false;
  std::string course, participant, station, script, answers;
  int trials = 0;  // 0: the study's count
  std::optional<uint64_t> seed;
  std::vector<std::string> sets;  // --set KEY=VALUE
};

int run_simulator(const RunArgs& args) {
#ifdef CARIESIM_HAS_VIEWER
  viewer::ViewerOptions options;
  options.scene = args.scene;
  options.overrides = scene_overrides(args.sets);
  options.device = args.device;
  options.device_profile = args.device_profile;
  options.rate_hz = args.rate;
  options.record = args.record;
  options.overwrite = args.overwrite;
  options.show_lesions = args.show_lesions;
  options.spin_us = args.spin_us;
  options.standby = !args.no_standby;
  options.trainee = args.trainee;
  options.course = args.course;
  options.participant = args.participant;
  options.station = args.station;
  options.script = args.script;
  options.answers = args.answers;
  if (args.trials > 0) options.trials = args.trials;
  options.seed = args.seed;
  return open_window(args.window, std::move(options));
#else
  (void)args;
  return without_viewer();
#endif
}

struct ReviewArgs {
  std::string database;
  std::string participant;
  int trial = 0;  // 0: the participant's last ended trial
  WindowArgs window;
};

int run_review(const ReviewArgs& args) {
#ifdef CARIESIM_HAS_VIEWER
  // The window on the trial rebuilt from the database, replaying its recording (docs/training.md).
  viewer::ViewerOptions options;
  options.review = args.database;
  options.review_participant = args.participant;
  if (args.trial > 0) options.review_trial = args.trial;
  options.device = "null";
  return open_window(args.window, std::move(options));
#else
  (void)args;
  return without_viewer();
#endif
}

}  // namespace

void register_review(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<ReviewArgs>();
  CLI::App* sub = app.add_subcommand(
      "review",
      "Open the debrief of a past diagnosis trial of a study database: its lesions, the marks, the "
      "scores in words and the replay (docs/training.md)");
  sub->add_option("database", args->database, "The study database (e.g. records/chair-3.db)")->required();
  sub->add_option("--participant", args->participant, "The participant (default: the only one in the file)");
  sub->add_option("--trial", args->trial,
                  "The participant's N-th trial in the file, from 1 (default: their last ended trial)")
      ->check(CLI::Range(1, 1000000));
  add_window_options(sub, args->window,
                     "Exit after this many seconds of the replay's servo time (automation)");
  registry.add(sub, [args] { return run_review(*args); });
}

void register_run(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* sub = app.add_subcommand("run", "Open the simulator window (the default without a subcommand)");
  sub->add_option("scene,--scene", args->scene, "Built-in scene name or scene YAML file")
      ->capture_default_str();
  sub->add_option("--device", args->device, device_help("mouse | "))->capture_default_str();
  add_device_profile_option(sub, args->device_profile);
  add_set_option(sub, args->sets);
  sub->add_option("--rate", args->rate, "Servo rate in Hz (default: the scene's, 1000)")
      ->check(finite_range(1.0, 10000.0));
  auto* record = sub->add_option("--record", args->record, "Record the session into this SQLite file");
  sub->add_flag("--overwrite", args->overwrite, "Replace an existing record file")->needs(record);
  add_window_options(sub, args->window, "Exit after this many seconds of servo time (automation)");
  auto* show = sub->add_flag("--show-lesions", args->show_lesions,
                             "Start with the lesions revealed (hidden by default)");
  auto* trainee = sub->add_flag("--trainee", args->trainee,
                                "Trainee mode: nothing on screen shows a lesion (no lesion panel, readouts, "
                                "overlays or reveal key)");
  auto* course = sub->add_option("--course", args->course,
                                 "Course file: trainee mode running its study (docs/instructors.md)");
  sub->add_option("--participant", args->participant, "Participant ID for the course's study (else asked)")
      ->needs(course);
  sub->add_option("--station", args->station, "This station's name (overrides the course file's)")
      ->needs(course);
  sub->add_option("--answers", args->answers,
                  "Answers file that plays the participant (the format of `cariesim study run --answers`)")
      ->needs(course);
  sub->add_option("--trials", args->trials, "Override the course study's trial count")
      ->check(CLI::Range(1, 1000))
      ->needs(course);
  add_seed_option(sub, args->seed, "The course study's seed (default: the study file's, else drawn)")
      ->needs(course);
  sub->add_option("--script", args->script,
                  "Window script for automation: timed key presses and passphrases (docs/viewer.md)");
  show->excludes(trainee)->excludes(course);
  course->excludes(record);  // a course's trials record themselves
  add_spin_option(sub, args->spin_us);
  add_standby_option(sub, args->no_standby);
  registry.add(sub, [args] { return run_simulator(*args); });
  registry.set_default([args] { return run_simulator(*args); });
}

}  // namespace cariesim::cli
