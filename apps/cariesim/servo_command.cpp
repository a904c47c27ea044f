// `cariesim servo [--scene S] [--device SPEC] [--rate HZ] [--duration S] [--record FILE]`: the real-time
// servo loop without a window (docs/design.md §5). It drives the engine from any device (null,
// scripted:FILE, replay:FILE, udp:PORT: the UDP bridge of docs/device-bridge.md), prints a status line
// per second and, at the end, the loop's timing (step time and jitter percentiles, overruns), the
// device's counters and what was recorded. The device, the loop and the record come from one Session
// (servo/session.hpp), as in the viewer.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/udp_device.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/servo/session.hpp"
#include "commands.hpp"
#include "progress_printer.hpp"

namespace cariesim::cli {

namespace {

struct ServoArgs {
  std::string scene = "oral-cavity";
  std::string device = "null";
  std::string device_profile;  // a hardware device's profile file
  double rate = 0.0;           // Hz; 0 = the scene's servo rate
  double duration = 0.0;       // s; 0 = until the device ends or Ctrl-C
  std::string record;          // SQLite file, optional
  bool overwrite = false;      // replace an existing record file
  double force_scale = 1.0;    // global force scale in [0, 1]
  bool no_realtime = false;
  double spin_us = kDefaultSpinUs;  // µs polled before each deadline
  bool no_standby = false;          // no standby servo thread (ServoOptions::standby)
  bool quiet = false;
  std::vector<std::string> sets;  // --set KEY=VALUE
};

// The exit status of a run whose recording failed (disk full, I/O error): the run itself ended
// normally, but what was asked for was not all written (the committed prefix is a valid recording).
constexpr int kExitRecordingFailed = 4;

// s a hardware device may stay lost (unplugged, its service stopped) before the run ends.
constexpr double kLostDevice = 1.0;

// Set by SIGINT/SIGTERM/SIGHUP; the main thread polls it.
volatile std::sig_atomic_t g_interrupted = 0;
// Every force stops in the next cycle (request_force_stop), before the session shuts down.
extern "C" void on_interrupt(int /*signal*/) {
  request_force_stop();
  g_interrupted = 1;
}

// "|F|=... state depth" of the latest snapshot, once per second.
void print_status(const ServoSnapshot& s) {
  std::fprintf(stderr,
               "servo: t=%7.2f s  %-10s |F|=%6.3f N  |tau|=%7.2f N.mm  depth=%.3f mm  contacts=%d  %s  "
               "rate=%.0f Hz  overruns=%llu  work-budget=%llu  safety=0x%02x\n",
               s.t, state_name(s.out.state), s.force.norm(), s.torque.norm(), s.out.depth, s.out.contacts,
               s.device.valid ? "input ok" : "no input", s.rate_hz,
               static_cast<unsigned long long>(s.overruns), static_cast<unsigned long long>(s.work_budget),
               s.safety_flags);
}

// The loop's timing report, the limits in force, the device's counters, the recorder's summary.
void print_report(Session& session) {
  ServoLoop& loop = session.loop();
  const TimingReport r = loop.timing();
  std::fprintf(stderr,
               "servo: %llu cycles at %.1f Hz (target %.0f Hz), %llu overruns, %llu steps cut short by the "
               "work budget, %llu cycles run by the standby thread; real-time: %s; polls the last %.0f us of "
               "each wait\n"
               "  step time (us): p50 %.2f  p99 %.2f  p99.9 %.2f  max %.2f\n"
               "  jitter    (us): p50 %.2f  p99 %.2f  p99.9 %.2f  max %.2f\n",
               static_cast<unsigned long long>(r.cycles), r.rate_hz, 1.0 / loop.dt(),
               static_cast<unsigned long long>(r.overruns), static_cast<unsigned long long>(r.work_budget),
               static_cast<unsigned long long>(r.standby_cycles), loop.realtime_status().c_str(),
               loop.spin_us(), r.step_p50, r.step_p99, r.step_p999, r.step_max, r.jitter_p50, r.jitter_p99,
               r.jitter_p999, r.jitter_max);
  const Params& params = session.params();
  std::fprintf(stderr, "  limits: %.4g N, %.4g N/mm, %.4g N.mm; coupling %.4g N/mm\n",
               params.limits.max_force, params.limits.max_stiffness, params.limits.max_torque,
               params.gains.k_trans);
  ParamProblem refusal;
  if (loop.latest_refusal(refusal))
    std::fprintf(stderr, "  device limits refused %llu times, last: %s %s\n",
                 static_cast<unsigned long long>(loop.refused_limits()), refusal.field, refusal.rule);
  const Device& device = session.device();
  const auto counters = device.counters();
  if (!counters.empty()) {
    std::fprintf(stderr, "  device %s:", device.info().name.c_str());
    for (const DeviceCounter& c : counters)
      std::fprintf(stderr, " %s=%llu", c.name, static_cast<unsigned long long>(c.value));
    std::fprintf(stderr, "\n");
  }
  if (const auto* haptic = dynamic_cast<const HapticDevice*>(&device)) {
    const HapticStatus st = haptic->status();
    std::fprintf(stderr, "  %s %s: %s; calibration: %s; force %s; %s", st.hardware.backend.c_str(),
                 st.hardware.model.c_str(), st.rendering().c_str(), st.calibration.message.c_str(),
                 st.force_was_enabled ? "was enabled" : "never enabled",
                 st.hardware.dof_out >= 6 ? "\n" : "");
    if (st.hardware.dof_out < 6)
      std::fprintf(stderr, "; torque dropped in %llu cycles (largest %.1f N.mm)\n",
                   static_cast<unsigned long long>(st.torque_dropped), st.torque_dropped_max);
  }
  if (const auto* udp = dynamic_cast<const UdpDevice*>(&device))
    std::fprintf(stderr, "  bridge threads: %s\n", udp->realtime_status().c_str());
  if (const Recorder* recorder = session.recorder()) {
    const RecorderStatus st = recorder->status();
    std::fprintf(stderr, "  recorded %llu samples, %llu events to %s (%llu dropped by the loop)%s%s\n",
                 static_cast<unsigned long long>(st.written), static_cast<unsigned long long>(st.events),
                 recorder->file().string().c_str(), static_cast<unsigned long long>(loop.dropped_samples()),
                 st.ok ? "" : "; failed: ", st.message.c_str());
  }
}

int run_servo(const ServoArgs& args) {
  // The model, then the session: its device, servo loop and (with --record) recorder.
  BuildOptions build;
  if (!args.quiet) build.progress = progress_printer();
  const Model model = build_model(load_scene(args.scene, scene_overrides(args.sets)), build);
  SessionOptions options;
  // The record names the scene with its overrides (the scene hash covers them too).
  options.scene = args.scene;
  for (const std::string& set : args.sets) options.scene += " --set " + set;
  options.device = args.device;
  options.device_profile = args.device_profile;
  options.rate_hz = args.rate;
  options.realtime = !args.no_realtime;
  options.spin_us = args.spin_us;
  options.standby = !args.no_standby;
  options.safety.force_scale = args.force_scale;
  options.record = args.record;
  options.recorder.overwrite = args.overwrite;
  Session session(model, options);
  if (!session.warning().empty()) std::fprintf(stderr, "warning: %s\n", session.warning().c_str());
  // A scripted or replayed path that does not loop ends the run when it ends.
  const std::string device_name = session.device_info().name;
  const bool ends = (device_name == "scripted" || device_name == "replay") && !args.device.ends_with(":loop");

  // A closed terminal (SIGHUP) ends the run like Ctrl-C: the record is closed with its end time.
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  std::signal(SIGHUP, on_interrupt);
  session.start();
  const DeviceInfo& info = session.device_info();
  if (!args.quiet) {
    const std::string until = args.duration > 0.0 ? "for " + std::to_string(args.duration) + " s"
                              : ends              ? "until the path ends or Ctrl-C"
                                                  : "until Ctrl-C";
    std::fprintf(stderr, "servo: %s on %s at %.0f Hz (%s); real-time: %s; %s\n", info.name.c_str(),
                 args.scene.c_str(), session.rate_hz(), info.description.c_str(),
                 session.loop().realtime_status().c_str(), until.c_str());
  }

  // Watch the snapshots: a status line per second, the end of the path, the duration, Ctrl-C, a
  // hardware device lost for longer than kLostDevice (its force is zero from the first cycle; the run
  // and its record then end cleanly, saying why).
  const auto* haptic = dynamic_cast<const HapticDevice*>(&session.device());
  double lost_since = -1.0;
  const auto started = std::chrono::steady_clock::now();
  double next_status = 1.0;
  bool seen_valid = false;
  ServoSnapshot snapshot;
  while (g_interrupted == 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (session.latest(snapshot)) {
      if (!args.quiet && elapsed >= next_status) {
        print_status(snapshot);
        next_status += 1.0;
      }
      if (ends && seen_valid && !snapshot.device.valid) break;
      seen_valid = seen_valid || snapshot.device.valid;
    }
    if (args.duration > 0.0 && elapsed >= args.duration) break;
    if (haptic != nullptr) {
      const uint32_t faults = haptic->status().faults;
      if ((faults & kHardwareLost) == 0) {
        lost_since = -1.0;
      } else if (lost_since < 0.0) {
        lost_since = elapsed;
      } else if (elapsed - lost_since > kLostDevice) {
        std::fprintf(stderr, "servo: the device was lost (%s); ending the run\n",
                     describe_hardware_faults(faults).c_str());
        break;
      }
    }
  }
  // The loop and the device stop before the recorder, which then drains and closes.
  session.stop();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::signal(SIGHUP, SIG_DFL);
  print_report(session);
  if (const Recorder* recorder = session.recorder(); recorder != nullptr && !recorder->status().ok) {
    std::fprintf(stderr, "error: %s\n", recorder->status().message.c_str());
    return kExitRecordingFailed;
  }
  return 0;
}

}  // namespace

std::string device_help(const std::string& extra) {
  return extra +
         "null | scripted:FILE[:loop] | replay:FILE[:loop] | udp:PORT[:HOST] | touch[:NAME] | "
         "fd[:INDEX|SERIAL] | haply[:URL] (docs/devices.md)";
}

void add_device_profile_option(CLI::App* sub, std::string& profile) {
  sub->add_option("--device-profile", profile,
                  "A hardware device's profile (YAML: frame mapping, scale, stylus offset, buttons; "
                  "docs/devices.md); default: the backend's built-in one");
}

void add_spin_option(CLI::App* sub, double& spin_us) {
  sub->add_option("--spin-us", spin_us,
                  "Microseconds before each deadline the servo thread polls the clock instead of sleeping "
                  "(at most half the period; 0 sleeps)")
      ->check(finite_range(0.0, kMaxSpinUs))
      ->capture_default_str();
}

void add_standby_option(CLI::App* sub, bool& no_standby) {
  sub->add_flag("--no-standby", no_standby,
                "No standby servo thread on a second CPU (it runs the cycles the servo thread's CPU was "
                "taken from)");
}

void register_servo(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<ServoArgs>();
  CLI::App* sub = app.add_subcommand("servo", "Run the real-time servo loop with a device, without a window");
  sub->add_option("--scene", args->scene, "Built-in scene name or scene YAML file")->capture_default_str();
  sub->add_option("--device", args->device, device_help())->capture_default_str();
  add_device_profile_option(sub, args->device_profile);
  add_set_option(sub, args->sets);
  sub->add_option("--rate", args->rate, "Servo rate in Hz, up to 10000 (default: the scene's)")
      ->check(finite_range(1.0, 10000.0));
  sub->add_option("--duration", args->duration, "Seconds to run (default: until a path ends, or Ctrl-C)")
      ->check(finite_range(0.0, 1e9));
  auto* record =
      sub->add_option("--record", args->record, "Record the session to this SQLite file (must not exist)");
  sub->add_flag("--overwrite", args->overwrite, "Replace an existing record file")->needs(record);
  sub->add_option("--force-scale", args->force_scale, "Global force scale")
      ->check(finite_range(0.0, 1.0))
      ->capture_default_str();
  sub->add_flag("--no-realtime", args->no_realtime, "Do not ask for SCHED_FIFO priority");
  add_spin_option(sub, args->spin_us);
  add_standby_option(sub, args->no_standby);
  sub->add_flag("--quiet", args->quiet, "Only the final report");
  registry.add(sub, [args] { return run_servo(*args); });
}

}  // namespace cariesim::cli
