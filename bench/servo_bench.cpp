// The servo loop on oral-cavity with the scripted device following scenes/trajectories/servo-touch-46.csv
// (onto tooth 46, into the fossa over lesion #1, across the crown; it loops).
//
// BM_ServoLoopOralCavity: the real ServoLoop thread, 10 s at 1 kHz and at 4 kHz, each polling the
//   last kDefaultSpinUs before its deadlines (ServoOptions::spin_us; at most half the period) and
//   sleeping to them (spin_us 0). Reports step time (one cycle's work) and jitter (wake-up lateness)
//   percentiles, overruns, cycles and the measured rate as counters, and the real-time status as the
//   label. CARIESIM_SERVO_BENCH_SECONDS overrides the 10 s.
// BM_ServoCycleOralCavity: the same cycle's work back to back on this thread (no sleeping), 10000
//   cycles at dt = 1 ms = the whole path once, repeated 5 times: Google Benchmark's mean/median per
//   cycle plus the per-cycle percentiles.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <string>
#include <thread>

#include "cariesim/device/devices.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/scene/trajectory.hpp"
#include "cariesim/servo/servo.hpp"

namespace {

using namespace cariesim;

const Model& oral_cavity() {
  static const Model model = build_model(load_scene("oral-cavity"));
  return model;
}

// This thread's CPU time (µs).
double thread_cpu_us() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) * 1e-3;
}

double run_seconds() {
  const char* env = std::getenv("CARIESIM_SERVO_BENCH_SECONDS");
  const double s = env != nullptr ? std::atof(env) : 10.0;
  return s > 0.0 ? s : 10.0;
}

void BM_ServoLoopOralCavity(benchmark::State& state) {
  Model model = oral_cavity();
  const Trajectory path = load_trajectory_csv(CARIESIM_SOURCE_DIR "/scenes/trajectories/servo-touch-46.csv");
  ServoOptions options;
  options.rate_hz = static_cast<double>(state.range(0));
  options.spin_us = static_cast<double>(state.range(1));
  options.realtime = true;
  SpscQueue<ServoSample> samples(1 << 16);
  options.record = &samples;
  TimingReport report;
  std::string status;
  uint64_t contact_cycles = 0, total_samples = 0;
  for (auto _ : state) {
    ScriptedDevice device(path, true, "servo-touch-46.csv", model.defaults.limits);
    ServoLoop loop(model, device, options);
    loop.start();
    status = loop.realtime_status();
    // Drain the samples as a recorder would, counting the cycles in contact.
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(run_seconds());
    ServoSample s;
    while (std::chrono::steady_clock::now() < end) {
      while (samples.pop(s)) {
        ++total_samples;
        contact_cycles += s.state != InteractionState::Free;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    loop.stop();
    while (samples.pop(s)) {
      ++total_samples;
      contact_cycles += s.state != InteractionState::Free;
    }
    report = loop.timing();
  }
  state.counters["step_p50_us"] = report.step_p50;
  state.counters["step_p99_us"] = report.step_p99;
  state.counters["step_p999_us"] = report.step_p999;
  state.counters["step_max_us"] = report.step_max;
  state.counters["jitter_p50_us"] = report.jitter_p50;
  state.counters["jitter_p99_us"] = report.jitter_p99;
  state.counters["jitter_p999_us"] = report.jitter_p999;
  state.counters["jitter_max_us"] = report.jitter_max;
  state.counters["cycles"] = static_cast<double>(report.cycles);
  state.counters["overruns"] = static_cast<double>(report.overruns);
  state.counters["rate_hz"] = report.rate_hz;
  state.counters["contact_frac"] =
      total_samples > 0 ? static_cast<double>(contact_cycles) / static_cast<double>(total_samples) : 0.0;
  state.SetLabel(status);
}
BENCHMARK(BM_ServoLoopOralCavity)
    ->ArgNames({"rate_hz", "spin_us"})
    ->Args({1000, static_cast<int64_t>(kDefaultSpinUs)})
    ->Args({1000, 0})
    ->Args({4000, static_cast<int64_t>(kDefaultSpinUs)})
    ->Args({4000, 0})
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

// One servo cycle's work without the thread or its sleeps, as ServoLoop::cycle does it: the scripted
// device read, the engine step with dt = 1 ms, the safety filter. One benchmark iteration is one
// cycle of servo-touch-46.csv at 1 kHz (the path loops); the per-cycle times go into TimingHistograms:
// wall time as step_p50_us ... step_max_us, this thread's CPU time as cpu_p50_us ... cpu_max_us (what
// the cycle costs, without the time a loaded machine took the core away).
void BM_ServoCycleOralCavity(benchmark::State& state) {
  const Model& model = oral_cavity();
  const Trajectory path = load_trajectory_csv(CARIESIM_SOURCE_DIR "/scenes/trajectories/servo-touch-46.csv");
  ScriptedDevice device(path, true, "servo-touch-46.csv", model.defaults.limits);
  device.start();
  State sim(model, model.tool_home);
  ForceSafety safety;
  TimingHistogram cycle_us, cycle_cpu_us;
  constexpr double kDt = 0.001;  // s, 1 kHz
  double t = 0.0;
  uint64_t contact_cycles = 0;
  for (auto _ : state) {
    const auto begin = std::chrono::steady_clock::now();
    const double cpu_begin = thread_cpu_us();
    const DeviceState input = device.read(t);
    const StepOutput out = step(model, sim, HapticInput{input.pose, kDt});
    Vec3 force = out.force;
    Vec3 torque = out.torque;
    safety.filter(force, torque, input, t);
    device.write(force, torque);
    cycle_cpu_us.add(thread_cpu_us() - cpu_begin);
    cycle_us.add(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - begin).count());
    benchmark::DoNotOptimize(force);
    contact_cycles += out.state != InteractionState::Free;
    t += kDt;
  }
  state.counters["step_p50_us"] = cycle_us.percentile(0.5);
  state.counters["step_p99_us"] = cycle_us.percentile(0.99);
  state.counters["step_p999_us"] = cycle_us.percentile(0.999);
  state.counters["step_max_us"] = cycle_us.max();
  state.counters["cpu_p50_us"] = cycle_cpu_us.percentile(0.5);
  state.counters["cpu_p99_us"] = cycle_cpu_us.percentile(0.99);
  state.counters["cpu_p999_us"] = cycle_cpu_us.percentile(0.999);
  state.counters["cpu_max_us"] = cycle_cpu_us.max();
  state.counters["contact_frac"] =
      static_cast<double>(contact_cycles) / static_cast<double>(state.iterations());
}
// 10000 cycles = the whole 10 s path once.
BENCHMARK(BM_ServoCycleOralCavity)->Iterations(10000)->Repetitions(5)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
