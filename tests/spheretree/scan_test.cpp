// Sphere trees of the real tooth scans (issue 2 acceptance): tight mode within 0.02 mm at p95 and
// 0.05 mm at worst with at most 50,000 leaves; the paper's depth-4 octree for comparison. And the
// shipped data (issue #12): all sixteen teeth of data/open-full-jaw/patient26 load and build.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "cariesim/spheretree/build.hpp"
#include "spheretree/test_shapes.hpp"

namespace cariesim {
namespace {

// One scan, its level set for the default tight parameters, loaded once per test program.
struct Scan {
  TriangleMesh mesh;
  LevelSet shape;
};

const Scan* scan(const std::string& tooth) {
  static std::map<std::string, Scan> loaded;
  const auto it = loaded.find(tooth);
  if (it != loaded.end()) return &it->second;
  const auto path = testing::scan_path(tooth);
  if (path.empty()) return nullptr;
  Scan s;
  s.mesh = load_mesh(path);
  const LevelSetResolution res = choose_resolution(s.mesh, TreeParams{});
  s.shape = LevelSet::from_mesh(s.mesh, res.voxel, res.half_band);
  return &loaded.emplace(tooth, std::move(s)).first->second;
}

class ScanTree : public ::testing::TestWithParam<std::string> {};

TEST_P(ScanTree, TightModeMeetsTheFidelityTarget) {
  const Scan* s = scan(GetParam());
  if (!s) GTEST_SKIP() << "no scan " << GetParam() << " under " << CARIESIM_DATA_DIR;
  const TreeParams params;
  const SphereTree tree = build_sphere_tree(s->shape, params);
  EXPECT_EQ(check_tree(tree), "");
  EXPECT_LE(tree.leaf_count(), 50000u);
  const Deviation dev = measure_deviation(tree, s->mesh, s->shape, 100000, 1);
  std::printf("%s tight: %s\n", GetParam().c_str(),
              format_tree_report_json(make_tree_report(tree, 0.0, dev)).c_str());
  EXPECT_LE(dev.p95, 0.02);
  EXPECT_LE(dev.max, 0.05);
  EXPECT_LE(dev.max_poke_out, 0.05);
  EXPECT_LE(dev.max_fall_short, 0.05);
}

INSTANTIATE_TEST_SUITE_P(Teeth, ScanTree, ::testing::Values("tooth_19", "tooth_30"),
                         [](const auto& info) { return info.param; });

TEST(ScanOctree, DepthFourCoversTheSurface) {
  const auto path = testing::scan_path("tooth_30");
  if (path.empty()) GTEST_SKIP() << "no scan tooth_30 under " << CARIESIM_DATA_DIR;
  const TriangleMesh mesh = load_mesh(path);
  TreeParams params;
  params.mode = TreeMode::Octree;
  params.depth = 4;
  const LevelSetResolution res = choose_resolution(mesh, params);
  const LevelSet shape = LevelSet::from_mesh(mesh, res.voxel, res.half_band);
  const SphereTree tree = build_sphere_tree(shape, params);
  EXPECT_LE(tree.leaf_count(), 4096u);
  EXPECT_EQ(check_tree(tree, 1e-4), "");
  const Deviation dev = measure_deviation(tree, mesh, shape, 100000, 1);
  std::printf("tooth_30 octree: %s\n", format_tree_report_json(make_tree_report(tree, 0.0, dev)).c_str());
  EXPECT_LE(dev.max_fall_short, 0.0);  // every surface sample inside some leaf
  EXPECT_GT(dev.p50, 0.2);             // the paper's fidelity, about half a millimetre
}

// The repository ships these files, so a missing one fails here (the other tests skip). Each tooth is
// a closed genus-0 surface with the README's triangle count and builds a valid tight tree (0.05 mm:
// the validity of every tooth, not the fidelity the tests above measure on two of them); the axes
// file gives each tooth but the third molars a centre inside its crown's bounds.
TEST(ShippedScans, EveryToothLoadsAndBuildsAValidTree) {
  const std::filesystem::path dir = std::filesystem::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26";
  constexpr std::array<std::size_t, 16> kTriangles = {35504, 37452, 43980, 25700, 20968, 24876, 19760, 16744,
                                                      15916, 19560, 24604, 20616, 24344, 45040, 33168, 32000};
  const std::filesystem::path axes_file = dir / "teeth_axes_mandible.json";
  ASSERT_TRUE(std::filesystem::is_regular_file(axes_file)) << "missing " << axes_file;
  const YAML::Node axes = YAML::LoadFile(axes_file.string());
  for (int n = 17; n <= 32; ++n) {
    SCOPED_TRACE("tooth_" + std::to_string(n));
    const std::filesystem::path file = dir / ("tooth_" + std::to_string(n) + ".ply");
    ASSERT_TRUE(std::filesystem::is_regular_file(file)) << "missing " << file;
    MeshReport report;
    const TriangleMesh mesh = load_mesh(file, &report);
    EXPECT_TRUE(report.watertight());
    EXPECT_EQ(report.components, 1u);
    EXPECT_EQ(report.degenerate_removed, 0u);
    EXPECT_EQ(mesh.triangles.size(), kTriangles[static_cast<std::size_t>(n - 17)]);
    EXPECT_EQ(static_cast<long>(mesh.vertices.size()) - static_cast<long>(mesh.triangles.size()) / 2, 2);
    EXPECT_GT(mesh.volume(), 100.0);  // mm^3: an incisor with its root is about 300

    TreeParams params;
    params.tolerance = 0.05;
    params.max_radius = 1.5;
    const LevelSetResolution res = choose_resolution(mesh, params);
    const SphereTree tree = build_sphere_tree(LevelSet::from_mesh(mesh, res.voxel, res.half_band), params);
    EXPECT_EQ(check_tree(tree), "");
    EXPECT_GT(tree.leaf_count(), 500u);

    const YAML::Node a = axes[std::to_string(n)];
    if (n == 17 || n == 32) {
      EXPECT_FALSE(a.IsDefined()) << "the data set gives no axes for the third molars";
      continue;
    }
    ASSERT_TRUE(a.IsMap());
    const Vec3 c(a["c"][0].as<double>(), a["c"][1].as<double>(), a["c"][2].as<double>());
    const Eigen::AlignedBox3d bounds = mesh.bounds();
    EXPECT_TRUE(bounds.contains(c)) << "centre " << c.transpose();
  }
}

}  // namespace
}  // namespace cariesim
