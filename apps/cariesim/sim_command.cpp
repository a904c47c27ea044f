// `cariesim sim --scene S --trajectory T.csv --out O.csv [--rate HZ]` (docs/design.md §6): headless run of
// the haptic step along a trajectory, one CSV row per servo cycle, streamed to the file as the run
// goes (constant memory; runs of more than kMaxSimSteps steps are refused up front).
#include <cstdio>
#include <filesystem>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/experiment/simulate.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/servo/servo.hpp"
#include "commands.hpp"
#include "progress_printer.hpp"

namespace cariesim::cli {

namespace {

struct SimArgs {
  std::string scene = "oral-cavity";
  std::string trajectory;
  std::string out;
  double rate = 0.0;  // Hz; 0 = the scene's servo rate
  bool quiet = false;
  std::vector<std::string> sets;  // --set KEY=VALUE
};

// The output must not be the trajectory it reads: the same path, or the same file through a link.
void refuse_same_file(const std::string& trajectory, const std::string& out) {
  std::error_code ec;
  const bool same = trajectory == out || std::filesystem::equivalent(trajectory, out, ec);
  if (same && !ec)
    throw Error(out + ": --out is the trajectory file itself (" + trajectory +
                "); writing it would destroy the input: choose another output file");
}

int run_sim(const SimArgs& args) {
  refuse_same_file(args.trajectory, args.out);
  const Trajectory trajectory = load_trajectory_csv(args.trajectory);
  if (args.rate > 0.0) (void)sim_step_count(trajectory, args.rate);  // refused before the build
  BuildOptions build;
  if (!args.quiet) build.progress = progress_printer();
  const Model model = build_model(load_scene(args.scene, scene_overrides(args.sets)), build);
  const double rate = args.rate > 0.0 ? args.rate : model.servo_rate;
  (void)sim_step_count(trajectory, rate);  // an absurd span is refused before the output is created

  // Streamed: each row is written as its step is made; memory stays constant however long the run.
  // The summary keeps counts and a step-time histogram, not the samples.
  SimCsvWriter out(args.out);
  TimingHistogram step_us;
  int counts[4] = {0, 0, 0, 0};
  const std::size_t steps = simulate_each(model, model.defaults, trajectory, rate, [&](const SimSample& s) {
    out.write(s);
    step_us.add(s.out.step_us);
    ++counts[static_cast<int>(s.out.state)];
  });
  out.close();

  // A short summary: steps, states visited, step time percentiles.
  if (!args.quiet) {
    std::fprintf(
        stderr,
        "sim: %zu steps at %.0f Hz -> %s\n  states: free %d, sliding %d, inserting %d, extracting %d\n"
        "  step time: median %.1f us, p99 %.1f us, max %.1f us\n",
        steps, rate, args.out.c_str(), counts[0], counts[1], counts[2], counts[3], step_us.percentile(0.5),
        step_us.percentile(0.99), step_us.max());
  }
  return 0;
}

}  // namespace

void register_sim(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<SimArgs>();
  CLI::App* sub = app.add_subcommand("sim", "Drive the haptic tool along a trajectory CSV, headless");
  sub->add_option("--scene", args->scene, "Built-in scene name or scene YAML file")->capture_default_str();
  sub->add_option("--trajectory", args->trajectory,
                  "CSV with header t,px,py,pz,qw,qx,qy,qz (s, mm, unit quaternion)")
      ->required();
  sub->add_option("--out", args->out, "Output CSV, one row per servo step")->required();
  sub->add_option("--rate", args->rate, "Servo rate in Hz (default: the scene's)")
      ->check(finite_range(1.0, 100000.0));
  add_set_option(sub, args->sets);
  sub->add_flag("--quiet", args->quiet, "No progress or summary");
  registry.add(sub, [args] { return run_sim(*args); });
}

}  // namespace cariesim::cli
