// The headless run both `cariesim sim` and Python's Simulator.run call (simulate_each,
// experiment/simulate.hpp) over a 10 000-step trajectory on friction-block (docs/python.md, "Speed"):
// with the rows kept as Python keeps them (a copy per step into a preallocated buffer) and with the
// rows written as `cariesim sim` writes them (SimCsvWriter). bench/python_vs_sim.py times the two
// programs end to end on the same trajectory.
//
// Run: build/bench/sim_run_bench --benchmark_repetitions=5

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "cariesim/experiment/simulate.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace {

constexpr double kRate = 1000.0;  // Hz
constexpr int kSteps = 10000;     // servo steps of the trajectory

// Down onto the carious top, then along it and back, 10 s (the press and slide of tests/python).
cariesim::Trajectory press_and_slide() {
  cariesim::Trajectory t;
  const double span = (kSteps - 1) / kRate;  // s
  const cariesim::Quat q(
      Eigen::AngleAxisd(-50.0 * M_PI / 180.0, cariesim::Vec3::UnitY()));  // the scene's home
  for (int i = 0; i <= 100; ++i) {
    const double time = span * i / 100.0;
    const double phase = time / span;
    const double z = phase < 0.05 ? 1.0 - 1.6 * phase / 0.05 : -0.6;               // mm
    const double x = -20.0 + 15.0 * std::sin(M_PI * std::max(0.0, phase - 0.05));  // mm
    t.add(time, cariesim::Pose{cariesim::Vec3(x, 0.0, z), q});
  }
  return t;
}

const cariesim::Model& model() {
  static const cariesim::Model m = cariesim::build_model(cariesim::load_scene("friction-block"));
  return m;
}

// The run as Python's Simulator.run makes it: each sample copied into a buffer made beforehand.
void BM_RunIntoArray(benchmark::State& state) {
  const cariesim::Trajectory trajectory = press_and_slide();
  std::vector<cariesim::SimSample> rows(cariesim::sim_step_count(trajectory, kRate));
  for (auto _ : state) {
    std::size_t i = 0;
    cariesim::simulate_each(model(), model().defaults, trajectory, kRate,
                            [&](const cariesim::SimSample& s) { rows[i++] = s; });
    benchmark::DoNotOptimize(rows.data());
  }
  state.counters["steps"] = static_cast<double>(rows.size());
}
BENCHMARK(BM_RunIntoArray)->Unit(benchmark::kMillisecond)->UseRealTime();

// The run as `cariesim sim` makes it: each sample written as a CSV row.
void BM_RunIntoCsv(benchmark::State& state) {
  const cariesim::Trajectory trajectory = press_and_slide();
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "cariesim_sim_run_bench.csv";
  std::size_t steps = 0;
  for (auto _ : state) {
    cariesim::SimCsvWriter out(file);
    steps = cariesim::simulate_each(model(), model().defaults, trajectory, kRate,
                                    [&](const cariesim::SimSample& s) { out.write(s); });
    out.close();
  }
  std::filesystem::remove(file);
  state.counters["steps"] = static_cast<double>(steps);
}
BENCHMARK(BM_RunIntoCsv)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
