// The servo loop on oral-cavity with the scripted device following scenes/trajectories/servo-touch-46.csv
// (onto tooth 46, into the fossa over lesion #1, across the crown; it loops).
//
// BM_ServoLoopOralCavity: the real ServoLoop thread, 10 s at 1 kHz and at 4 kHz, each polling the
//   last kDefaultSpinUs before its deadlines (ServoOptions::spin_us; at most half the period) and
//   sleeping to them (spin_us 0), with and without the standby thread (ServoOptions::standby).
//   Reports step time (one cycle's work) and jitter (wake-up lateness) percentiles, overruns, the
//   cycles the standby ran, cycles and the measured rate as counters, and the real-time status as
//   the label. CARIESIM_SERVO_BENCH_SECONDS overrides the 10 s.
// BM_CoreLoss: how often this machine takes a CPU away from a thread that never yields it (issue
//   #11): one SCHED_FIFO thread per CPU asked for (the highest CPUs of the affinity), each pinned
//   and polling the clock for the same 10 s (CARIESIM_SERVO_BENCH_SECONDS), idle 50 ms in every
//   500 ms so that the kernel's real-time throttle (95 % of each second) never stops it. Every stretch
//   the clock jumped by more than 200 us is a loss: per minute and per thread over 200 us and over
//   1 ms, the longest, and how many of the first thread's losses overlapped one of the second's.
// BM_ServoCycleOralCavity: the same cycle's work back to back on this thread (no sleeping), 10000
//   cycles at dt = 1 ms = the whole path once, repeated 5 times: Google Benchmark's mean/median per
//   cycle plus the per-cycle percentiles.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/cpu.hpp"
#include "cariesim/device/devices.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
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
  options.standby = state.range(2) != 0;
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
  state.counters["standby_cycles"] = static_cast<double>(report.standby_cycles);
  state.counters["rate_hz"] = report.rate_hz;
  state.counters["contact_frac"] =
      total_samples > 0 ? static_cast<double>(contact_cycles) / static_cast<double>(total_samples) : 0.0;
  state.SetLabel(status);
}
BENCHMARK(BM_ServoLoopOralCavity)
    ->ArgNames({"rate_hz", "spin_us", "standby"})
    ->Args({1000, static_cast<int64_t>(kDefaultSpinUs), 1})
    ->Args({1000, static_cast<int64_t>(kDefaultSpinUs), 0})
    ->Args({1000, 0, 1})
    ->Args({4000, static_cast<int64_t>(kDefaultSpinUs), 1})
    ->Args({4000, static_cast<int64_t>(kDefaultSpinUs), 0})
    ->Args({4000, 0, 1})
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
    const StepOutput out = step(model, sim, HapticInput{input.pose, kDt, input.valid, t - input.stamp});
    Vec3 force = out.force;
    Vec3 torque = out.torque;
    safety.filter(force, torque, out.input_faults, t);
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

// The stretches (start, end; CLOCK_MONOTONIC ns) longer than 200 us in which a pinned SCHED_FIFO
// thread polling the clock on `cpu` did not run, over `seconds`; refused (empty, *ok false) without
// the CPU or the priority.
std::vector<std::pair<int64_t, int64_t>> core_losses(int cpu, double seconds, bool* ok) {
  *ok = pin_thread(pthread_self(), {cpu}) && set_fifo_priority(pthread_self(), 80) == 0;
  std::vector<std::pair<int64_t, int64_t>> losses;
  if (!*ok) return losses;
  losses.reserve(100000);
  constexpr int64_t kLoss = 200000, kBusy = 500000000, kIdle = 50000000;  // ns
  const int64_t start = monotonic_ns(), end = start + static_cast<int64_t>(seconds * 1e9);
  int64_t last = start, chunk = start + kBusy;
  while (last < end) {
    const int64_t now = monotonic_ns();
    if (now - last > kLoss && losses.size() < losses.capacity()) losses.emplace_back(last, now);
    last = now;
    if (now >= chunk) {  // the throttle's due, not a loss
      sleep_until_ns(now + kIdle);
      last = monotonic_ns();
      chunk = last + kBusy;
    }
  }
  return losses;
}

void BM_CoreLoss(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  std::vector<int> cpus = allowed_cpus();
  if (static_cast<int>(cpus.size()) < threads) {
    state.SkipWithError("fewer CPUs than threads");
    return;
  }
  cpus.resize(static_cast<std::size_t>(threads));
  std::vector<std::vector<std::pair<int64_t, int64_t>>> losses(cpus.size());
  bool ok[2] = {true, true};
  for (auto _ : state) {
    std::vector<std::thread> pool;
    for (std::size_t i = 0; i < cpus.size(); ++i)
      pool.emplace_back([&, i] { losses[i] = core_losses(cpus[i], run_seconds(), &ok[i]); });
    for (std::thread& t : pool) t.join();
  }
  if (!ok[0] || !ok[1]) {
    state.SkipWithError("SCHED_FIFO or the CPU refused");
    return;
  }
  const double minutes = run_seconds() / 60.0;
  for (std::size_t i = 0; i < cpus.size(); ++i) {
    const std::string cpu = "cpu" + std::to_string(cpus[i]);
    double over_1ms = 0, longest = 0;
    for (const auto& [a, b] : losses[i]) {
      over_1ms += b - a > 1000000;
      longest = std::max(longest, static_cast<double>(b - a) * 1e-3);
    }
    state.counters[cpu + "_over_200us_per_min"] = static_cast<double>(losses[i].size()) / minutes;
    state.counters[cpu + "_over_1ms_per_min"] = over_1ms / minutes;
    state.counters[cpu + "_longest_us"] = longest;
  }
  if (cpus.size() == 2) {
    double overlapping = 0;
    for (const auto& [a, b] : losses[0])
      overlapping += std::any_of(losses[1].begin(), losses[1].end(),
                                 [&](const auto& o) { return o.first < b && o.second > a; });
    state.counters["overlapping_losses"] = overlapping;
  }
}
BENCHMARK(BM_CoreLoss)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
