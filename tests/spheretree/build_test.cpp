#include "cariesim/spheretree/build.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/hierarchy.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "spheretree/test_shapes.hpp"
#include "spheretree/tree_checks.hpp"

namespace cariesim {
namespace {

using testing::distance_to_leaves;
using testing::make_box;
using testing::make_icosphere;

// The level set a scene would build for `mesh` with these parameters.
LevelSet level_set_for(const TriangleMesh& mesh, const TreeParams& params) {
  const LevelSetResolution res = choose_resolution(mesh, params);
  return LevelSet::from_mesh(mesh, res.voxel, res.half_band);
}

TEST(ChooseResolution, FollowsTheToleranceAndCapsBigObjects) {
  TreeParams tight;
  const LevelSetResolution tooth = choose_resolution(make_icosphere(5.0, 3), tight);
  EXPECT_NEAR(tooth.voxel, 0.05, 1e-12);
  EXPECT_NEAR(tooth.half_band, 5 * tooth.voxel, 1e-12);
  // The paper's 100 x 100 x 20 mm cube: the voxel grows so that the band stays within budget.
  const TriangleMesh cube = make_box(Vec3(-50, -50, -20), Vec3(50, 50, 0));
  const LevelSetResolution big = choose_resolution(cube, tight);
  EXPECT_GT(big.voxel, 0.1);
  EXPECT_LE(cube.area() / (big.voxel * big.voxel) * (2.0 * big.half_band / big.voxel), 2.0e7 * 1.0001);
  TreeParams octree;
  octree.mode = TreeMode::Octree;
  octree.depth = 4;
  EXPECT_NEAR(choose_resolution(make_box(Vec3(0, 0, 0), Vec3(16, 8, 8)), octree).voxel, 16.0 / 16 / 8, 1e-12);
  EXPECT_THROW((void)choose_resolution(TriangleMesh{}, tight), Error);
}

TEST(TightTree, SphereWithinToleranceAndInscribed) {
  TreeParams params;
  const TriangleMesh mesh = make_icosphere(3.0, 6);
  const LevelSet shape = level_set_for(mesh, params);
  const SphereTree tree = build_sphere_tree(shape, params);
  ASSERT_FALSE(tree.empty());
  EXPECT_EQ(tree.mode, TreeMode::Tight);
  EXPECT_EQ(check_tree(tree), "");
  EXPECT_LE(tree.leaf_count(), params.max_leaves);

  const Deviation dev = measure_deviation(tree, mesh, shape, 100000, 2);
  EXPECT_EQ(dev.samples, 100000u);
  EXPECT_LE(dev.p95, 0.02);
  EXPECT_LE(dev.max, 0.05);
  EXPECT_LE(dev.p50, dev.p95);
  EXPECT_LE(dev.p95, dev.max);

  // Every surface leaf is inscribed (radius = distance to the surface, within the clip allowance)
  // and no larger than max_radius; fillers stay inside.
  std::size_t fillers = 0;
  for (uint32_t n : tree.leaf_nodes) {
    const SphereNode& s = tree.nodes[n];
    const double depth = 3.0 - s.center.cast<double>().norm();
    EXPECT_LE(s.radius - depth, 0.2 * params.tolerance + 0.005);
    if (s.flags & kLeafInterior) {
      ++fillers;
    } else {
      EXPECT_LE(s.radius, params.max_radius + 1e-6);
    }
  }
  EXPECT_GT(fillers, 0u);
  // The solid is solid: deep points lie inside some leaf.
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(1.2, -0.7, 0.4), Vec3(-2.0, 0.5, 0.3)}) {
    EXPECT_LT(distance_to_leaves(tree, p), 0.0) << p.transpose();
  }
}

TEST(TightTree, BoxEdgesGetSmallSpheresFacesLargeOnes) {
  TreeParams params;
  params.tolerance = 0.02;
  params.max_radius = 1.5;
  const TriangleMesh mesh = make_box(Vec3(-3, -3, -1.5), Vec3(3, 3, 1.5));
  const LevelSet shape = level_set_for(mesh, params);
  const SphereTree tree = build_sphere_tree(shape, params);
  EXPECT_EQ(check_tree(tree), "");
  const Deviation dev = measure_deviation(tree, mesh, shape, 100000, 3);
  EXPECT_LE(dev.p95, params.tolerance);
  // The level set rounds the sharp edges by up to a quarter voxel when they fall between voxel
  // centres (here by 0.017 mm), which adds to the worst case along them.
  EXPECT_LE(dev.max, 3.0 * params.tolerance);
  // The sphere touching the middle of the top face is large, the one at a corner small.
  const SphereNode& face = testing::nearest_leaf(tree, Vec3(0.1, 0.2, 1.5));
  const SphereNode& corner = testing::nearest_leaf(tree, Vec3(3, 3, 1.5));
  EXPECT_GT(face.radius, 1.0);
  EXPECT_LT(corner.radius, 0.2);
}

TEST(OctreeTree, PaperModeDepthFour) {
  TreeParams params;
  params.mode = TreeMode::Octree;
  params.depth = 4;
  const TriangleMesh mesh = make_icosphere(4.0, 5);
  const LevelSet shape = level_set_for(mesh, params);
  const SphereTree tree = build_sphere_tree(shape, params);
  EXPECT_EQ(tree.mode, TreeMode::Octree);
  EXPECT_EQ(tree.levels, 5);
  EXPECT_LE(tree.leaf_count(), 4096u);
  EXPECT_GT(tree.leaf_count(), 500u);
  EXPECT_EQ(check_tree(tree, 1e-4), "");  // every child inside its parent
  const auto per_level = tree.nodes_per_level();
  ASSERT_EQ(per_level.size(), 5u);
  for (std::size_t level = 0; level < per_level.size(); ++level) {
    EXPECT_LE(per_level[level], std::size_t(1) << (3 * level));
  }
  // All leaves share one radius, (sqrt(3)/2) * edge, and sit on the cell grid.
  const float r = tree.nodes[tree.leaf_nodes[0]].radius;
  const double edge = r / (0.5 * std::sqrt(3.0));
  const Vec3 root = tree.nodes[0].center.cast<double>();
  EXPECT_NEAR(tree.nodes[0].radius, 16 * r, 1e-3);
  for (uint32_t n : tree.leaf_nodes) {
    EXPECT_FLOAT_EQ(tree.nodes[n].radius, r);
    const Vec3 cell = (tree.nodes[n].center.cast<double>() - root) / edge - Vec3::Constant(0.5);
    EXPECT_LT((cell - cell.array().round().matrix()).cwiseAbs().maxCoeff(), 1e-3);
  }
  // Every surface sample is covered by the union of leaves.
  const Deviation dev = measure_deviation(tree, mesh, shape, 100000, 4);
  EXPECT_LE(dev.max_fall_short, 0.0);
  // The paper's fidelity: about half a millimetre.
  EXPECT_GT(dev.p50, 0.1);
  EXPECT_LT(dev.p50, 1.0);
}

TEST(OctreeTree, LeafCountIsBoundedAtEveryDepth) {
  TreeParams params;
  params.mode = TreeMode::Octree;
  const TriangleMesh mesh = make_box(Vec3(0, 0, 0), Vec3(4, 3, 2));
  const LevelSet shape = LevelSet::from_mesh(mesh, 0.05, 0.25);
  std::size_t previous = 0;
  for (int depth = 0; depth <= 4; ++depth) {
    params.depth = depth;
    const SphereTree tree = build_sphere_tree(shape, params);
    EXPECT_EQ(check_tree(tree), "") << depth;
    EXPECT_LE(tree.leaf_count(), std::size_t(1) << (3 * depth)) << depth;
    EXPECT_GE(tree.leaf_count(), previous) << depth;
    EXPECT_LE(measure_deviation(tree, mesh, shape, 20000, 1).max_fall_short, 0.0) << depth;
    previous = tree.leaf_count();
  }
}

// Caries = tooth ∩ lesion, healthy = tooth − lesion (paper §2.2), on a procedural tooth.
TEST(TreeLabels, CariesAndHealthyTreesSplitTheToothAtTheLesionWall) {
  const double r = 4.0;
  const TriangleMesh mesh = make_icosphere(r, 5);
  TreeParams params;
  const LevelSetResolution res = choose_resolution(mesh, params);
  const LevelSet tooth = LevelSet::from_mesh(mesh, res.voxel, res.half_band);
  LesionShape lesion;  // disk, diameter 2, 1.5 deep, on top
  lesion.center = Vec3(0, 0, r);
  lesion.normal = Vec3::UnitZ();
  const LevelSet lesion_ls = lesion.to_level_set(res.voxel, res.half_band);
  const LevelSet caries_ls = tooth.intersection(lesion_ls);
  const LevelSet healthy_ls = tooth.difference(lesion_ls);
  SphereTree caries = build_sphere_tree(caries_ls, params);
  SphereTree healthy = build_sphere_tree(healthy_ls, params);
  ASSERT_FALSE(caries.empty());
  ASSERT_EQ(check_tree(caries), "");
  ASSERT_EQ(check_tree(healthy), "");
  const double tol = params.tolerance;

  // Inside both tooth and lesion: inside a caries leaf, outside every healthy leaf.
  for (const Vec3& p : {Vec3(0, 0, r - 0.75), Vec3(0.5, 0.3, r - 0.4), Vec3(-0.6, 0.2, r - 1.2)}) {
    EXPECT_LT(distance_to_leaves(caries, p), 0.0) << p.transpose();
    EXPECT_GT(distance_to_leaves(healthy, p), 0.0) << p.transpose();
  }
  // On the lesion wall inside the tooth: on the surface of both trees.
  for (double angle = 0.0; angle < 6.2; angle += 0.9) {
    for (double depth : {0.3, 0.75, 1.2}) {
      const Vec3 p(std::cos(angle), std::sin(angle), r - depth);
      EXPECT_LE(std::abs(distance_to_leaves(healthy, p)), tol + 0.005) << p.transpose();
      EXPECT_LE(std::abs(distance_to_leaves(caries, p)), tol + 0.005) << p.transpose();
    }
  }
  // The two trees do not overlap beyond the tolerance.
  EXPECT_LE(testing::max_overlap(caries, healthy), tol);

  // Classification against the whole tooth: the wall is a lesion wall, the rest exposed.
  classify_leaves(healthy, tooth, 2.0 * tol);
  classify_leaves(caries, tooth, 2.0 * tol);
  EXPECT_TRUE(testing::nearest_leaf(healthy, Vec3(1.0, 0.0, r - 0.75)).flags & kLeafOnLesionWall);
  EXPECT_TRUE(testing::nearest_leaf(caries, Vec3(1.0, 0.0, r - 0.75)).flags & kLeafOnLesionWall);
  EXPECT_TRUE(testing::nearest_leaf(caries, Vec3(0.0, 0.0, r)).flags & kLeafOnExposedSurface);
  EXPECT_TRUE(testing::nearest_leaf(healthy, Vec3(0.0, 0.0, -r)).flags & kLeafOnExposedSurface);
  std::size_t interior = 0;
  for (std::size_t i = 0; i < healthy.leaf_count(); ++i) {
    const SphereNode& s = healthy.nodes[healthy.leaf_nodes[i]];
    // A leaf at the rim touches both the outer surface and the wall (one flag per tangent), but
    // an interior leaf touches neither.
    const bool surface = (s.flags & (kLeafOnExposedSurface | kLeafOnLesionWall)) != 0;
    EXPECT_NE(surface, bool(s.flags & kLeafInterior));
    if (s.flags & kLeafInterior) ++interior;
    // leaf_depth is the depth of the centre below the tooth's outer surface (beyond the narrow
    // band it comes from a coarser grid, good to a few hundredths of a millimetre).
    EXPECT_NEAR(healthy.leaf_depth[i], r - s.center.cast<double>().norm(), 0.04);
  }
  EXPECT_GT(interior, 0u);

  // Materials by depth.
  assign_materials(caries, [](const Vec3&, float depth) { return uint16_t(depth < 0.5f ? 7 : 9); });
  for (std::size_t i = 0; i < caries.leaf_count(); ++i) {
    EXPECT_EQ(caries.nodes[caries.leaf_nodes[i]].material, caries.leaf_depth[i] < 0.5f ? 7 : 9);
  }
}

TEST(MeasureDeviation, ClosedFormsOnASphere) {
  const TriangleMesh mesh = make_icosphere(2.0, 6);
  const LevelSet shape = LevelSet::from_mesh(mesh, 0.05, 0.25);
  const auto one_leaf = [](double radius) {
    LeafSphere leaf{Vec3f::Zero(), static_cast<float>(radius)};
    return build_hierarchy(std::vector<LeafSphere>{leaf});
  };
  const Deviation exact = measure_deviation(one_leaf(2.0), mesh, shape, 20000, 1);
  EXPECT_LT(exact.max, 0.002);
  const Deviation short_by = measure_deviation(one_leaf(1.9), mesh, shape, 20000, 1);
  EXPECT_NEAR(short_by.p50, 0.1, 0.002);
  EXPECT_NEAR(short_by.max_fall_short, 0.1, 0.002);
  EXPECT_LE(short_by.max_poke_out, 0.0);
  const Deviation over_by = measure_deviation(one_leaf(2.1), mesh, shape, 20000, 1);
  EXPECT_NEAR(over_by.p95, 0.1, 0.002);
  EXPECT_NEAR(over_by.max_poke_out, 0.1, 0.002);
  EXPECT_LE(over_by.max_fall_short, 0.0);

  // A small leaf poking out of the top by 0.05 mm shows on the leaf side too.
  std::vector<LeafSphere> leaves{{Vec3f::Zero(), 2.0f}, {Vec3f(0, 0, 1.95f), 0.1f}};
  const Deviation poke = measure_deviation(build_hierarchy(leaves), mesh, shape, 20000, 1);
  EXPECT_NEAR(poke.max_poke_out, 0.05, 0.003);
  // Same seed, same numbers.
  const Deviation again = measure_deviation(build_hierarchy(leaves), mesh, shape, 20000, 1);
  EXPECT_EQ(again.p95, poke.p95);
  EXPECT_THROW((void)measure_deviation(SphereTree{}, mesh, shape), Error);
  EXPECT_THROW((void)measure_deviation(one_leaf(1.0), TriangleMesh{}, shape), Error);
}

TEST(CheckTree, FindsBrokenTrees) {
  std::vector<LeafSphere> leaves;
  for (int i = 0; i < 20; ++i) leaves.push_back({Vec3f(float(i), float(i % 3), 0.0f), 0.4f});
  const SphereTree good = build_hierarchy(leaves, 4);
  ASSERT_EQ(check_tree(good), "");
  EXPECT_EQ(check_tree(SphereTree{}), "");

  SphereTree t = good;
  t.nodes[0].radius *= 0.5f;
  EXPECT_NE(check_tree(t).find("beyond"), std::string::npos);
  t = good;
  t.nodes[t.leaf_nodes[3]].leaf = 5;
  EXPECT_NE(check_tree(t).find("leaf index"), std::string::npos);
  t = good;
  t.leaf_depth.pop_back();
  EXPECT_NE(check_tree(t).find("leaf_depth"), std::string::npos);
  t = good;
  t.levels += 1;
  EXPECT_NE(check_tree(t).find("levels"), std::string::npos);
  t = good;
  t.nodes[0].first = 0;
  EXPECT_NE(check_tree(t).find("children"), std::string::npos);
  t = good;
  t.nodes[1].center.x() = std::nanf("");
  EXPECT_NE(check_tree(t).find("non-finite"), std::string::npos);
}

TEST(BuildSphereTree, RejectsBadParametersAndHandlesEmptyInput) {
  const LevelSet shape = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(1, 1, 1)), 0.05, 0.25);
  TreeParams p;
  p.tolerance = 0.0;
  EXPECT_THROW((void)build_sphere_tree(shape, p), Error);
  p = TreeParams{};
  p.max_radius = 0.01;  // below min_radius
  EXPECT_THROW((void)build_sphere_tree(shape, p), Error);
  p = TreeParams{};
  p.branching = 1;
  EXPECT_THROW((void)build_sphere_tree(shape, p), Error);
  p = TreeParams{};
  p.mode = TreeMode::Octree;
  p.depth = 9;
  EXPECT_THROW((void)build_sphere_tree(shape, p), Error);
  EXPECT_TRUE(build_sphere_tree(LevelSet{}, TreeParams{}).empty());
}

TEST(BuildSphereTree, LeafCapIsHonoured) {
  TreeParams p;
  p.max_leaves = 100;
  const LevelSet shape = LevelSet::from_mesh(make_icosphere(2.0, 4), 0.05, 0.25);
  const SphereTree tree = build_sphere_tree(shape, p);
  EXPECT_EQ(tree.leaf_count(), 100u);
  EXPECT_EQ(check_tree(tree), "");
}

TEST(BuildSphereTree, ReportsProgressUpToDone) {
  const LevelSet shape = LevelSet::from_mesh(make_icosphere(1.5, 4), 0.05, 0.25);
  for (TreeMode mode : {TreeMode::Tight, TreeMode::Octree}) {
    TreeParams p;
    p.mode = mode;
    std::vector<double> fractions;
    (void)build_sphere_tree(shape, p, [&](std::string_view, double f) { fractions.push_back(f); });
    ASSERT_FALSE(fractions.empty());
    EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
    EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
  }
}

TEST(TreeReport, FormatsOneLineOfJson) {
  const LevelSet shape = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(2, 2, 2)), 0.05, 0.25);
  TreeParams p;
  p.mode = TreeMode::Octree;
  p.depth = 2;
  const SphereTree tree = build_sphere_tree(shape, p);
  Deviation dev;
  dev.p50 = 0.25;
  dev.p95 = 0.5;
  dev.max = 0.75;
  dev.samples = 100000;
  const TreeReport report = make_tree_report(tree, 1.5, dev);
  EXPECT_EQ(report.leaves, tree.leaf_count());
  EXPECT_EQ(report.nodes_per_level, tree.nodes_per_level());
  const std::string json = format_tree_report_json(report);
  EXPECT_EQ(json.find('\n'), std::string::npos);
  EXPECT_EQ(json.front(), '{');
  EXPECT_EQ(json.back(), '}');
  EXPECT_NE(json.find("\"mode\":\"octree\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"leaves\":" + std::to_string(tree.leaf_count()) + ","), std::string::npos) << json;
  EXPECT_NE(json.find("\"levels\":3,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"build_seconds\":1.500"), std::string::npos) << json;
  EXPECT_NE(json.find("\"deviation_mm\":{\"p50\":0.2500,\"p95\":0.5000,\"max\":0.7500"), std::string::npos)
      << json;
  EXPECT_NE(json.find("\"samples\":100000"), std::string::npos) << json;
}

}  // namespace
}  // namespace cariesim
