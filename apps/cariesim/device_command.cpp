// `cariesim device list` and `cariesim device check SPEC [--force]` (docs/devices.md): which haptic
// SDKs and devices this station has, and a device's first minutes without a scene: open, calibrate
// or home, stream poses (the reach, the buttons, the rate and its jitter), and with --force a gentle
// spring.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/hardware.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "cariesim/device/profile.hpp"
#include "cariesim/device/shared_library.hpp"
#include "cariesim/record/replay.hpp"
#include "cariesim/servo/servo.hpp"
#include "commands.hpp"

namespace cariesim::cli {

namespace {

struct CheckArgs {
  std::string spec;
  std::string profile;
  bool force = false;
  double seconds = 3.0;         // s of poses
  double spring_seconds = 2.0;  // s of the spring (--force)
};

// N/mm and N: the check's spring, gentle on any device.
constexpr double kSpringStiffness = 0.1;
constexpr double kSpringMaxForce = 1.0;
// s, how long the check waits for the operator to calibrate (home) the device.
constexpr double kCalibrationWait = 60.0;

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_stop(int /*signal*/) { g_stop = 1; }

// One line per SDK, then one per device.
int list_devices() {
  int found = 0;
  for (const HardwareSurvey& survey : {survey_touch(), survey_fd(), survey_haply()}) {
    if (survey.sdk.path) {
      std::printf("%s: %s%s\n", survey.backend.c_str(), survey.sdk.path->c_str(),
                  survey.version.empty() ? "" : (" (version " + survey.version + ")").c_str());
    } else {
      std::printf("%s: %s\n", survey.backend.c_str(), survey.sdk.describe().c_str());
      if (!survey.install.empty()) std::printf("  install: %s\n", survey.install.c_str());
    }
    if (!survey.problem.empty() && survey.sdk.describe().find(survey.problem) == std::string::npos)
      std::printf("  %s\n", survey.problem.c_str());
    for (const HardwareInfo& d : survey.devices) {
      ++found;
      std::printf("  %s%s%s: %d-DoF in, %d-DoF out, %d buttons; %.2f N peak, %.2f N continuous, %.2f N/mm",
                  d.model.c_str(), d.serial.empty() ? "" : " #", d.serial.c_str(), d.dof_in, d.dof_out,
                  d.buttons, d.max_force, d.continuous_force, d.max_stiffness);
      if (d.dof_out >= 6) std::printf(", %.0f N.mm", d.max_torque);
      const Vec3 size = d.workspace.sizes();
      std::printf("; workspace %.0f x %.0f x %.0f mm\n", size.x(), size.y(), size.z());
    }
  }
  std::printf("%d device%s attached\n", found, found == 1 ? "" : "s");
  return 0;
}

// What the check saw.
struct CheckStats {
  uint64_t readings = 0, valid = 0;
  uint32_t buttons = 0;
  Eigen::AlignedBox3d reach;
  TimingHistogram intervals;         // us between readings
  double peak_force = 0.0;           // N, the spring's
  std::chrono::steady_clock::time_point last{};
};

// One cycle of the check on whichever thread clocks it: read, (spring), write.
struct CheckCycle {
  Device* device = nullptr;
  CheckStats stats;
  std::atomic<bool> spring{false};
  Vec3 anchor = Vec3::Zero();
  bool anchored = false;
  double t = 0.0, dt = 0.001;  // s
  void run() {
    const auto now = std::chrono::steady_clock::now();
    if (stats.readings > 0)
      stats.intervals.add(std::chrono::duration<double, std::micro>(now - stats.last).count());
    stats.last = now;
    const DeviceState s = device->read(t);
    t += dt;
    ++stats.readings;
    Vec3 force = Vec3::Zero();
    if (s.valid) {
      ++stats.valid;
      stats.buttons |= s.buttons;
      stats.reach.extend(s.pose.p);
      if (spring.load(std::memory_order_relaxed)) {
        if (!anchored) anchor = s.pose.p, anchored = true;
        force = -kSpringStiffness * (s.pose.p - anchor);
        if (force.norm() > kSpringMaxForce) force *= kSpringMaxForce / force.norm();
        stats.peak_force = std::max(stats.peak_force, force.norm());
      }
    }
    device->write(force, Vec3::Zero());
  }
  static void tick(void* context) { static_cast<CheckCycle*>(context)->run(); }
};

int check_device(const CheckArgs& args) {
  DeviceOptions options;
  if (!args.profile.empty()) {
    // Checked before the device is opened: a bad profile is named with its line and field.
    const DeviceProfile profile = load_device_profile(args.profile);
    std::printf("profile %s: scale %.3g, stylus offset %.1f mm\n", profile.origin.c_str(), profile.scale,
                profile.stylus_offset.norm());
    options.profile = args.profile;
  }
  register_replay_device();
  std::unique_ptr<Device> device = make_device(args.spec, options);
  std::signal(SIGINT, on_stop);
  std::signal(SIGTERM, on_stop);
  device->start();
  auto* haptic = dynamic_cast<HapticDevice*>(device.get());
  const DeviceInfo info = device->info();
  std::printf("device %s: %s\n", info.name.c_str(), info.description.c_str());

  // Calibration (homing): wait for the operator when the device asks for it.
  if (haptic != nullptr) {
    HapticStatus st = haptic->status();
    std::printf("  %d-DoF in, %d-DoF out; %s\n", st.hardware.dof_in, st.hardware.dof_out,
                st.rendering().c_str());
    const bool waited = st.calibration.readiness != Readiness::Ready;
    std::printf("  calibration: %s\n", st.calibration.message.c_str());
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(kCalibrationWait);
    while (st.calibration.readiness != Readiness::Ready && g_stop == 0 &&
           std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      st = haptic->status();
    }
    if (st.calibration.readiness != Readiness::Ready) {
      device->stop();
      std::fprintf(stderr, "error: %s not calibrated: %s\n", info.name.c_str(),
                   st.calibration.message.c_str());
      return 1;
    }
    if (waited) std::printf("  calibrated: %s\n", st.calibration.message.c_str());
  }

  // Poses for `seconds`, then the spring; clocked by the device when its SDK owns the servo thread.
  CheckCycle cycle;
  cycle.device = device.get();
  const double total = args.seconds + (args.force ? args.spring_seconds : 0.0);
  DeviceClock* clock = device->clock();
  std::atomic<bool> running{true};
  std::thread own;
  if (clock != nullptr) {
    cycle.dt = 1.0 / clock->rate_hz();
    clock->start_clock(&CheckCycle::tick, &cycle);
  } else {
    own = std::thread([&] {
      auto next = std::chrono::steady_clock::now();
      while (running.load()) {
        cycle.run();
        next += std::chrono::milliseconds(1);
        std::this_thread::sleep_until(next);
      }
    });
  }
  std::printf("  move the stylus through its workspace and press each button (%.0f s)\n", args.seconds);
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  while (g_stop == 0 && elapsed() < args.seconds) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  if (args.force && g_stop == 0) {
    std::printf("  force: a gentle spring (%.2f N/mm, at most %.1f N) holds the stylus for %.0f s\n",
                kSpringStiffness, kSpringMaxForce, args.spring_seconds);
    cycle.spring.store(true);
    while (g_stop == 0 && elapsed() < total) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (clock != nullptr) {
    clock->stop_clock();
  } else {
    running.store(false);
    own.join();
  }
  device->write(Vec3::Zero(), Vec3::Zero());
  const double seconds = elapsed();
  const HapticStatus st = haptic != nullptr ? haptic->status() : HapticStatus{};
  device->stop();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);

  // What it saw.
  const CheckStats& s = cycle.stats;
  std::printf(
      "  %llu readings (%llu valid) in %.2f s: %.1f Hz; interval p50 %.0f us, p99 %.0f us, max %.0f us\n",
      static_cast<unsigned long long>(s.readings), static_cast<unsigned long long>(s.valid), seconds,
      static_cast<double>(s.readings) / std::max(seconds, 1e-9), s.intervals.percentile(0.5),
      s.intervals.percentile(0.99), s.intervals.max());
  if (s.valid > 0) {
    const Vec3 size = s.reach.sizes();
    std::printf("  reached %.1f x %.1f x %.1f mm (scene frame)\n", size.x(), size.y(), size.z());
  }
  std::string buttons;
  for (int i = 0; i < 32; ++i)
    if ((s.buttons & (1u << i)) != 0) buttons += (buttons.empty() ? "" : ", ") + std::to_string(i);
  std::printf("  buttons pressed: %s\n", buttons.empty() ? "none" : buttons.c_str());
  if (args.force)
    std::printf("  spring: peak %.3f N; force %s\n", s.peak_force,
                haptic == nullptr || st.force_enabled ? "enabled" : "never enabled (see the calibration)");
  if (haptic != nullptr && st.faults != 0)
    std::printf("  last reading: %s\n", describe_hardware_faults(st.faults).c_str());
  if (s.valid == 0) {
    std::fprintf(stderr, "error: %s gave no valid reading\n", info.name.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

void register_device(CLI::App& app, Registry& registry) {
  auto* device = app.add_subcommand("device", "Haptic devices: the SDKs and devices found, a device's check");
  device->require_subcommand(1);
  auto* list = device->add_subcommand("list", "The haptic SDKs found (path, version), the devices attached");
  registry.add(list, [] { return list_devices(); });

  auto args = std::make_shared<CheckArgs>();
  auto* check = device->add_subcommand(
      "check", "Open a device, calibrate (home) it, stream its poses; with --force, a gentle spring");
  check->add_option("spec", args->spec, device_help())->required();
  add_device_profile_option(check, args->profile);
  check->add_flag("--force", args->force, "Render a gentle spring for 2 s after the poses");
  check->add_option("--seconds", args->seconds, "Seconds of poses")
      ->check(finite_range(0.1, 600.0))
      ->capture_default_str();
  registry.add(check, [args] { return check_device(*args); });
}

}  // namespace cariesim::cli
