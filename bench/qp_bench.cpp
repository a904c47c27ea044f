// QP solve time by row count on contact-like problems, cold and warm (docs/performance.md; target:
// median <= 3 us at up to 20 rows).
//
// Run: build/bench/qp_bench --benchmark_counters_tabular=true
// Counters: p50_us / p99_us per solve (from our own clock around each solve), rows, active rows,
// dual steps and warm-seeded rows per solve.
//
// Each problem is one step of a periodic sequence of slowly changing contacts: a probe pressed
// 0.3 mm into a surface and swaying, with rows n and (p x n) for unit normals n (mostly up, some
// lateral: fissure walls) and lever arms p of 0-30 mm along the shaft; b = -gap with gaps of a few
// tenths of a millimetre drifting per step, rigid rows feasible at x = 0, a third compliant (caries,
// gingiva: 0.5-3 mm/N). Keys persist across steps, as sphere-pair ids do in the haptic step.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "cariesim/solver/qp.hpp"

namespace {

using cariesim::kQpMaxRows;
using cariesim::QpProblem;
using cariesim::QpResult;
using cariesim::QpRow;
using cariesim::QpSolver;
using cariesim::QpStatus;
using cariesim::Vec3;
using cariesim::Vec6;

constexpr int kSteps = 1024;  // problems per sequence; the sequence is periodic

// The static description of one contact row, animated per step.
struct ContactSeed {
  Vec3 normal;        // unit, at rest
  Vec3 wobble;        // unit, perpendicular to the normal: the direction the normal sways in
  Vec3 lever;         // mm, contact point relative to the tool origin
  double gap;         // mm, mean gap
  double compliance;  // mm/N
  int phase;          // steps
  int harmonic;       // cycles per sequence
};

// A periodic sequence of `rows`-row problems (see the file comment).
std::vector<QpProblem> contact_sequence(int rows, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<ContactSeed> seeds;
  for (int i = 0; i < rows; ++i) {
    ContactSeed c;
    Vec3 n(normal(rng), normal(rng), 0.0);
    // Two thirds floor contacts (normal within ~40 degrees of +z), a third walls (lateral normals).
    n.z() = unit(rng) < 0.67 ? 1.2 + unit(rng) : 0.3 * normal(rng);
    c.normal = n.normalized();
    c.wobble = c.normal.unitOrthogonal();
    c.lever = Vec3(0.3 * normal(rng), 0.3 * normal(rng), 30.0 * unit(rng));
    const bool compliant = unit(rng) < 0.33;
    c.compliance = compliant ? 0.5 + 2.5 * unit(rng) : 0.0;
    c.gap = compliant ? -0.05 + 0.45 * unit(rng) : 0.05 + 0.4 * unit(rng);
    c.phase = static_cast<int>(rng() % kSteps);
    c.harmonic = 1 + static_cast<int>(rng() % 4);
    seeds.push_back(c);
  }
  std::vector<QpProblem> sequence(kSteps);
  for (int t = 0; t < kSteps; ++t) {
    QpProblem& pb = sequence[t];
    pb.G = (Vec6() << 1.0, 1.0, 1.0, 500.0, 500.0, 500.0).finished().asDiagonal();
    const double w = 2.0 * std::numbers::pi * t / kSteps;
    pb.x_target << 0.3 * std::sin(w), 0.3 * std::cos(2.0 * w), -0.3 + 0.05 * std::sin(3.0 * w),
        0.01 * std::sin(w), 0.01 * std::cos(w), 0.005 * std::sin(2.0 * w);
    for (int i = 0; i < rows; ++i) {
      const ContactSeed& c = seeds[i];
      const double wi = 2.0 * std::numbers::pi * c.harmonic * (t + c.phase) / kSteps;
      const Vec3 n = (c.normal + 0.05 * std::sin(wi) * c.wobble).normalized();
      const Vec3 p = c.lever + Vec3(0.1 * std::cos(wi), 0.1 * std::sin(wi), 0.0);
      QpRow row;
      row.a << n, p.cross(n);
      // Rigid gaps stay >= 0 so x = 0 stays feasible; compliant rows may start penetrated.
      const double gap = c.gap + 0.04 * std::sin(wi);
      row.b = -(c.compliance > 0.0 ? gap : std::max(gap, 0.0));
      row.compliance = c.compliance;
      row.key = static_cast<uint64_t>(i + 1);
      pb.add(row);
    }
  }
  return sequence;
}

// Per-solve timing samples -> p50/p99 counters (microseconds) and solve statistics.
void run(benchmark::State& state, bool warm) {
  const int rows = static_cast<int>(state.range(0));
  const std::vector<QpProblem> sequence = contact_sequence(rows, 1234 + static_cast<uint64_t>(rows));
  QpSolver solver;
  QpResult result;
  // One untimed pass, so a warm run starts in the periodic regime.
  for (const QpProblem& pb : sequence) solver.solve(pb, result, warm);
  std::vector<double> us;
  us.reserve(1 << 20);
  long active = 0, iterations = 0, seeded = 0, optimal = 0, solves = 0;
  std::size_t step = 0;
  for (auto _ : state) {
    const QpProblem& pb = sequence[step];
    step = step + 1 == sequence.size() ? 0 : step + 1;
    const auto t0 = std::chrono::steady_clock::now();
    const QpStatus status = solver.solve(pb, result, warm);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(result.x.data());
    if (us.size() < us.capacity()) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    active += result.active;
    iterations += result.iterations;
    seeded += result.seeded;
    optimal += status == QpStatus::Optimal ? 1 : 0;
    ++solves;
  }
  if (us.empty() || solves == 0) return;
  const auto percentile = [&us](double q) {
    const std::size_t k =
        std::min(us.size() - 1, static_cast<std::size_t>(q * static_cast<double>(us.size())));
    std::nth_element(us.begin(), us.begin() + static_cast<std::ptrdiff_t>(k), us.end());
    return us[k];
  };
  state.counters["p50_us"] = percentile(0.50);
  state.counters["p99_us"] = percentile(0.99);
  state.counters["rows"] = rows;
  state.counters["active"] = static_cast<double>(active) / static_cast<double>(solves);
  state.counters["steps"] = static_cast<double>(iterations) / static_cast<double>(solves);
  state.counters["seeded"] = static_cast<double>(seeded) / static_cast<double>(solves);
  state.counters["optimal"] = static_cast<double>(optimal) / static_cast<double>(solves);
}

void BM_QpCold(benchmark::State& state) { run(state, false); }
void BM_QpWarm(benchmark::State& state) { run(state, true); }

void row_counts(benchmark::internal::Benchmark* b) {
  for (const int rows : {4, 8, 12, 20, 32, 64, kQpMaxRows}) b->Arg(rows);
}

}  // namespace

BENCHMARK(BM_QpCold)->Apply(row_counts)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_QpWarm)->Apply(row_counts)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
