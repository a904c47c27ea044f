// Sphere-tree building on a real lower molar (tooth_30 = FDI 46, 45k triangles) and the tree cache.
//
// - TightBuild: the whole offline path for one tooth at the default parameters (tolerance 0.015 mm,
//   max radius 1 mm): mesh -> level set (voxel 0.05 mm) -> tight tree. Target <= 10 s.
// - TightTreeOnly: the tree from a prebuilt level set (what the builder itself costs).
// - OctreeDepth4: the paper's mode, level set at the octree's resolution -> depth-4 octree.
// - CacheHit: loading the stored tight tree and its display mesh from the on-disk cache. Target
//   <= 0.1 s ("a cache hit loads in milliseconds", docs/design.md §3).
// - BoundaryCube: the paper's §4.2.2 block (100 x 100 x 20 mm) with a hidden 60 x 60 mm square
//   lesion 3 mm deep, tight mode at tolerance 0.1 mm and max radius 10 mm: level sets, CSG, the
//   healthy and the caries trees. Shows that a big flat-faced object stays within time and memory.
//
// Each runs one iteration per repetition; the aggregates (median first) are what to read.
// Run: build/bench/spheretree_bench --benchmark_report_aggregates_only=true

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <optional>
#include <string>

#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/cache.hpp"
#include "cariesim/spheretree/lesion.hpp"

namespace cariesim {
namespace {

// The scan, loaded once; nullptr when the shipped file is missing.
const TriangleMesh* tooth() {
  static const std::optional<TriangleMesh> mesh = []() -> std::optional<TriangleMesh> {
    const std::filesystem::path path =
        std::filesystem::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26" / "tooth_30.ply";
    if (!std::filesystem::exists(path)) return std::nullopt;
    return load_mesh(path);
  }();
  return mesh ? &*mesh : nullptr;
}

LevelSet level_set(const TriangleMesh& mesh, const TreeParams& params) {
  const LevelSetResolution res = choose_resolution(mesh, params);
  return LevelSet::from_mesh(mesh, res.voxel, res.half_band);
}

void TightBuild(benchmark::State& state) {
  const TriangleMesh* mesh = tooth();
  if (!mesh) {
    state.SkipWithError("skipped: no tooth_30.ply under " CARIESIM_DATA_DIR "/open-full-jaw/patient26");
    return;
  }
  const TreeParams params;
  std::size_t leaves = 0;
  for (auto _ : state) {
    const SphereTree tree = build_sphere_tree(level_set(*mesh, params), params);
    leaves = tree.leaf_count();
    benchmark::DoNotOptimize(tree.nodes.data());
  }
  state.counters["leaves"] = static_cast<double>(leaves);
}

void TightTreeOnly(benchmark::State& state) {
  const TriangleMesh* mesh = tooth();
  if (!mesh) {
    state.SkipWithError("skipped: no tooth_30.ply under " CARIESIM_DATA_DIR "/open-full-jaw/patient26");
    return;
  }
  const TreeParams params;
  const LevelSet shape = level_set(*mesh, params);
  for (auto _ : state) {
    const SphereTree tree = build_sphere_tree(shape, params);
    benchmark::DoNotOptimize(tree.nodes.data());
  }
}

void OctreeDepth4(benchmark::State& state) {
  const TriangleMesh* mesh = tooth();
  if (!mesh) {
    state.SkipWithError("skipped: no tooth_30.ply under " CARIESIM_DATA_DIR "/open-full-jaw/patient26");
    return;
  }
  TreeParams params;
  params.mode = TreeMode::Octree;
  params.depth = 4;
  std::size_t leaves = 0;
  for (auto _ : state) {
    const SphereTree tree = build_sphere_tree(level_set(*mesh, params), params);
    leaves = tree.leaf_count();
    benchmark::DoNotOptimize(tree.nodes.data());
  }
  state.counters["leaves"] = static_cast<double>(leaves);
}

void CacheHit(benchmark::State& state) {
  const TriangleMesh* mesh = tooth();
  if (!mesh) {
    state.SkipWithError("skipped: no tooth_30.ply under " CARIESIM_DATA_DIR "/open-full-jaw/patient26");
    return;
  }
  // Build and store once, outside the timed region.
  const TreeParams params;
  const LevelSet shape = level_set(*mesh, params);
  CachedPart part;
  part.tree = build_sphere_tree(shape, params);
  part.display = shape.to_mesh();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cariesim-bench-cache-" + std::to_string(::getpid()));
  const TreeCache cache(dir);
  const uint64_t key = BuildKey().add("tooth_30").add(params.tolerance).value();
  cache.store(key, part);
  std::size_t bytes = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    bytes += std::filesystem::file_size(e.path());
  for (auto _ : state) {
    const auto loaded = cache.load(key);
    if (!loaded) state.SkipWithError("the cache entry did not load");
    benchmark::DoNotOptimize(loaded);
  }
  std::filesystem::remove_all(dir);
  state.counters["leaves"] = static_cast<double>(part.tree.leaf_count());
  state.counters["display_triangles"] = static_cast<double>(part.display.triangles.size());
  state.counters["file_MB"] = static_cast<double>(bytes) / 1e6;
}

void BoundaryCube(benchmark::State& state) {
  const TriangleMesh cube = make_cuboid(Vec3(100.0, 100.0, 20.0));
  TreeParams params;
  params.tolerance = 0.1;
  params.max_radius = 10.0;
  LesionShape lesion;
  lesion.kind = LesionShape::Kind::Polygon;
  lesion.polygon = LesionShape::square(60.0);
  lesion.depth = 3.0;
  std::size_t healthy_leaves = 0;
  std::size_t caries_leaves = 0;
  for (auto _ : state) {
    const LevelSetResolution res = choose_resolution(cube, params);
    const LevelSet block = LevelSet::from_mesh(cube, res.voxel, res.half_band);
    const LevelSet hidden = lesion.to_level_set(res.voxel, res.half_band);
    const SphereTree healthy = build_sphere_tree(block.difference(hidden), params);
    const SphereTree caries = build_sphere_tree(block.intersection(hidden), params);
    healthy_leaves = healthy.leaf_count();
    caries_leaves = caries.leaf_count();
  }
  state.counters["healthy_leaves"] = static_cast<double>(healthy_leaves);
  state.counters["caries_leaves"] = static_cast<double>(caries_leaves);
}

BENCHMARK(TightBuild)->Unit(benchmark::kSecond)->Iterations(1)->Repetitions(3)->UseRealTime();
BENCHMARK(TightTreeOnly)->Unit(benchmark::kSecond)->Iterations(1)->Repetitions(3)->UseRealTime();
BENCHMARK(OctreeDepth4)->Unit(benchmark::kSecond)->Iterations(1)->Repetitions(3)->UseRealTime();
BENCHMARK(CacheHit)->Unit(benchmark::kMillisecond)->Iterations(5)->Repetitions(5)->UseRealTime();
BENCHMARK(BoundaryCube)->Unit(benchmark::kSecond)->Iterations(1)->Repetitions(3)->UseRealTime();

}  // namespace
}  // namespace cariesim

BENCHMARK_MAIN();
