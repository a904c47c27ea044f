// Offline geometry: build time of each procedural shape and load time of a real scan.
//
// Run: build/bench/geometry_bench --benchmark_counters_tabular=true
// Each case runs 5 repetitions; the median is the number to quote. Counters: triangles (and spheres
// for the explorer chain) of the result.

#include <benchmark/benchmark.h>

#include <filesystem>

#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"

namespace {

using namespace cariesim;

void set_counters(benchmark::State& state, const TriangleMesh& mesh) {
  state.counters["triangles"] = static_cast<double>(mesh.triangles.size());
}

void BM_MakeMolar(benchmark::State& state) {
  MolarParams p;
  p.resolution = static_cast<double>(state.range(0)) / 1000.0;
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = make_molar(p));
  set_counters(state, mesh);
}
BENCHMARK(BM_MakeMolar)
    ->Arg(150)
    ->Arg(250)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

void BM_MakePremolar(benchmark::State& state) {
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = make_premolar());
  set_counters(state, mesh);
}
BENCHMARK(BM_MakePremolar)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_MakeCuboid(benchmark::State& state) {
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = make_cuboid(Vec3(100, 100, 20)));
  set_counters(state, mesh);
}
BENCHMARK(BM_MakeCuboid)->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_MakeGingivaBand(benchmark::State& state) {
  // A lower arch segment from the second premolar to the second molar, margin at z = 0.
  GingivaParams g;
  g.path = {Vec3(-18, -4, 0), Vec3(-9, 0, 0), Vec3(0, 1, 0), Vec3(9, 0, 0), Vec3(18, -4, 0)};
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = make_gingiva_band(g));
  set_counters(state, mesh);
}
BENCHMARK(BM_MakeGingivaBand)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_MakeTongue(benchmark::State& state) {
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = make_tongue());
  set_counters(state, mesh);
}
BENCHMARK(BM_MakeTongue)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_MakeExplorerMesh(benchmark::State& state) {
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = make_explorer_mesh());
  set_counters(state, mesh);
}
BENCHMARK(BM_MakeExplorerMesh)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_MakeExplorerSpheres(benchmark::State& state) {
  std::vector<ToolSphere> spheres;
  for (auto _ : state) benchmark::DoNotOptimize(spheres = make_explorer_spheres());
  state.counters["spheres"] = static_cast<double>(spheres.size());
}
BENCHMARK(BM_MakeExplorerSpheres)->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_LoadScan(benchmark::State& state) {
  const std::filesystem::path file =
      std::filesystem::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26" / "tooth_30.ply";
  if (!std::filesystem::exists(file)) {
    state.SkipWithError(("skipped: the shipped scan is missing: " + file.string()).c_str());
    return;
  }
  MeshLoadOptions options;
  options.check_self_intersections = state.range(0) != 0;
  TriangleMesh mesh;
  for (auto _ : state) benchmark::DoNotOptimize(mesh = load_mesh(file, nullptr, options));
  set_counters(state, mesh);
}
BENCHMARK(BM_LoadScan)
    ->ArgName("self_intersections")
    ->Arg(1)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
