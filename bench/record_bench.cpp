// Recorder write throughput and crash exposure at 1 kHz and 10 kHz sample rates.
//
// BM_RecordThroughput: 10 s of samples queued before start(), then start() -> stop() timed: how fast
//   the writer thread turns the stream into committed batches (samples/s; the headroom over the
//   servo rate), with the batch counts, COMMIT times and the file size per sample.
// BM_RecordPaced: a servo-like producer pushes at the real rate for 2 s; every cycle it samples how
//   much pushed sample time is not yet committed (what a crash at that moment would lose):
//   p50/p99/max in ms, and the process CPU time per second of recording.
// BM_ReplayFirstPose: a recording of N s at 4 kHz (60 s: 55 MB; 600 s: 10 minutes, 550 MB) played
//   with `--device replay:`: the time from opening the file to the first pose the servo thread can
//   read, the memory the replay device takes (resident set growth) and the samples it holds, which
//   stay at most kReplayReadAhead however long the recording (the whole file was loaded before: 1.1
//   GB and 20 s for the 10-minute one).
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/record/recorder.hpp"
#include "cariesim/record/replay.hpp"

namespace {

using cariesim::Quat;
using cariesim::Recorder;
using cariesim::RecorderOptions;
using cariesim::ServoSample;
using cariesim::SessionInfo;
using cariesim::Vec3;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// A sample with every field populated (no zero columns SQLite could store in 0 bytes).
ServoSample sample(std::size_t i, double rate) {
  const double phase = static_cast<double>(i) * 0.01;
  ServoSample s;
  s.t = static_cast<double>(i) / rate;
  s.haptic.p = Vec3(10.0 * std::cos(phase), 10.0 * std::sin(phase), 0.001 * static_cast<double>(i));
  s.haptic.q = Quat(Eigen::AngleAxisd(0.3 * std::sin(phase), Vec3(1, 2, 3).normalized()));
  s.graphic.p = s.haptic.p + Vec3(0.01, -0.02, 0.5 * std::sin(phase));
  s.graphic.q = Quat(Eigen::AngleAxisd(0.2 * std::cos(phase), Vec3(0, 1, 0)));
  s.force = Vec3(std::sin(phase), -2.0 * std::cos(phase), 3.0 + std::sin(0.5 * phase));
  s.torque = Vec3(10.0 * std::sin(phase), 0.25, -7.5 * std::cos(phase));
  s.state = cariesim::InteractionState::Sliding;
  s.depth = 0.1f;
  s.step_us = 25.0f + static_cast<float>(std::sin(phase));
  s.soft_tissue_force = 0.2f;
  s.contacts = 3;
  return s;
}

SessionInfo session(double rate) {
  SessionInfo info;
  info.scene = "bench";
  info.device = "null";
  info.rate_hz = rate;
  return info;
}

fs::path bench_file() {
  return fs::temp_directory_path() / ("cariesim_record_bench_" + std::to_string(getpid()) + ".db");
}

double process_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(p * static_cast<double>(values.size() - 1))];
}

void BM_RecordThroughput(benchmark::State& state) {
  const double rate = static_cast<double>(state.range(0));
  const auto count = static_cast<std::size_t>(10.0 * rate);
  const fs::path file = bench_file();
  RecorderOptions options;
  options.overwrite = true;
  options.queue_capacity = count;
  cariesim::RecorderStatus status;
  double file_bytes = 0.0;
  for (auto _ : state) {
    Recorder recorder(file, session(rate), options);
    for (std::size_t i = 0; i < count; ++i) recorder.queue().push(sample(i, rate));
    const auto start = Clock::now();
    recorder.start();
    recorder.stop();
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - start).count());
    status = recorder.status();
    if (!status.ok) state.SkipWithError(status.message.c_str());
    file_bytes = static_cast<double>(fs::file_size(file));
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * count));
  state.counters["batches"] = static_cast<double>(status.batches);
  state.counters["max_batch_samples"] = static_cast<double>(status.max_batch_samples);
  state.counters["mean_batch_samples"] =
      static_cast<double>(status.written) / static_cast<double>(status.batches);
  state.counters["mean_commit_us"] = status.total_commit_us / static_cast<double>(status.batches);
  state.counters["max_commit_us"] = status.max_commit_us;
  state.counters["bytes_per_sample"] = file_bytes / static_cast<double>(count);
  fs::remove(file);
}
BENCHMARK(BM_RecordThroughput)
    ->Arg(1000)
    ->Arg(10000)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

void BM_RecordPaced(benchmark::State& state) {
  const double rate = static_cast<double>(state.range(0));
  const auto count = static_cast<std::size_t>(2.0 * rate);
  const fs::path file = bench_file();
  RecorderOptions options;
  options.overwrite = true;
  std::vector<double> exposure_ms;
  exposure_ms.reserve(count);
  double cpu_per_second = 0.0;
  for (auto _ : state) {
    Recorder recorder(file, session(rate), options);
    recorder.start();
    const double cpu0 = process_cpu_seconds();
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
    auto deadline = Clock::now();
    for (std::size_t i = 0; i < count; ++i) {
      recorder.queue().push(sample(i, rate));
      exposure_ms.push_back(1000.0 * static_cast<double>(i + 1 - recorder.written()) / rate);
      deadline += period;
      std::this_thread::sleep_until(deadline);
    }
    cpu_per_second = (process_cpu_seconds() - cpu0) / 2.0;
    recorder.stop();
    if (!recorder.status().ok) state.SkipWithError(recorder.status().message.c_str());
  }
  state.counters["uncommitted_p50_ms"] = percentile(exposure_ms, 0.5);
  state.counters["uncommitted_p99_ms"] = percentile(exposure_ms, 0.99);
  state.counters["uncommitted_max_ms"] = percentile(exposure_ms, 1.0);
  state.counters["cpu_s_per_s"] = cpu_per_second;
  fs::remove(file);
}
BENCHMARK(BM_RecordPaced)->Arg(1000)->Arg(10000)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

// kB of resident memory (VmRSS of /proc/self/status).
double resident_kb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6));
  return 0.0;
}

// The recordings BM_ReplayFirstPose made, by length (s); removed when the program ends.
std::map<double, fs::path> long_recordings;

// A recording of `seconds` s at `rate` Hz, written once per length and kept for the repetitions.
fs::path long_recording(double seconds, double rate) {
  std::map<double, fs::path>& made = long_recordings;
  if (const auto it = made.find(seconds); it != made.end()) return it->second;
  const fs::path file = fs::temp_directory_path() / ("cariesim_replay_bench_" + std::to_string(getpid()) +
                                                     "_" + std::to_string(static_cast<int>(seconds)) + ".db");
  RecorderOptions options;
  options.overwrite = true;
  Recorder recorder(file, session(rate), options);
  recorder.start();
  const auto count = static_cast<std::size_t>(seconds * rate);
  for (std::size_t i = 0; i < count; ++i)
    while (!recorder.queue().push(sample(i, rate)))
      std::this_thread::sleep_for(std::chrono::microseconds(200));
  recorder.stop();
  made[seconds] = file;
  return file;
}

void BM_ReplayFirstPose(benchmark::State& state) {
  constexpr double kRate = 4000.0;  // Hz
  const double seconds = static_cast<double>(state.range(0));
  const fs::path file = long_recording(seconds, kRate);
  double growth_kb = 0.0;
  std::size_t held = 0;
  for (auto _ : state) {
    const double before = resident_kb();
    const auto start = Clock::now();
    const auto replay = cariesim::make_replay_device(file, false);
    benchmark::DoNotOptimize(replay->read(0.0).pose.p.x());
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - start).count());
    growth_kb = resident_kb() - before;
    held = replay->max_buffered_samples();
  }
  state.counters["file_mb"] = static_cast<double>(fs::file_size(file)) / 1e6;
  state.counters["rss_growth_mb"] = growth_kb / 1024.0;
  state.counters["held_samples"] = static_cast<double>(held);
}
BENCHMARK(BM_ReplayFirstPose)
    ->Arg(60)
    ->Arg(600)
    ->UseManualTime()
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond);

// The recordings made for BM_ReplayFirstPose are removed after the run.
int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  for (const auto& [seconds, file] : long_recordings) {
    std::error_code ec;
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(file.string() + suffix, ec);
  }
  return 0;
}
