// Seam leaves (issue #10): the leaves that close the groove where a lesion meets the surface stay
// inside the object, reach at most the overlap across the cut, follow the uncut surface across the
// border, and make the parts' union match that surface there where the cut trees alone leave a groove.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "test_shapes.hpp"

namespace cariesim {
namespace {

// A 6 x 6 x 3 mm block (top face at z = 0) and a disk lesion 3 mm across, 1 mm deep, in its top.
struct CutBlock {
  TriangleMesh mesh = testing::make_box(Vec3(-3.0, -3.0, -3.0), Vec3(3.0, 3.0, 0.0));
  LesionShape lesion;
  TreeParams params;
  LevelSet object, healthy, caries;
  CutBlock() {
    lesion.kind = LesionShape::Kind::Disk;
    lesion.center = Vec3::Zero();
    lesion.size = 3.0;
    lesion.depth = 1.0;
    params.tolerance = 0.03;
    params.max_radius = 1.0;
    params.min_radius = 0.05;
    const double voxel = 0.1;
    object = LevelSet::from_mesh(mesh, voxel, 5 * voxel);
    const LevelSet cut = lesion.to_level_set(voxel, 5 * voxel);
    healthy = object.difference(cut);
    caries = object.intersection(cut);
  }
};

TEST(SeamLeaves, StayInsideAndReachAcrossTheCutByTheOverlapAtMost) {
  const CutBlock b;
  const SeamParams seam;
  const auto parts = build_seam_leaves(b.object, std::span<const LesionShape>(&b.lesion, 1), b.params, seam);
  ASSERT_EQ(parts.size(), 2u);
  ASSERT_FALSE(parts[0].empty());
  ASSERT_FALSE(parts[1].empty());
  for (std::size_t part = 0; part < 2; ++part) {
    for (const LeafSphere& l : parts[part]) {
      const Vec3 c = l.center.cast<double>();
      const double d = b.lesion.distance(c);
      // Centre on its part's side; at most the overlap across the cut.
      if (part == 0) {
        EXPECT_GE(d, 0.0);
        EXPECT_LE(l.radius - d, seam.overlap_mm + 1e-4);
      } else {
        EXPECT_LT(d, 0.0);
        EXPECT_LE(l.radius + d, seam.overlap_mm + 1e-4);
      }
      // Inside the block (top face z = 0) and tangent to its top, within the band.
      const double tol = seam.tolerance_for(b.params.tolerance);
      EXPECT_LE(c.z() + l.radius, 0.2 * tol + 1e-4);
      EXPECT_NEAR(c.z() + l.radius, 0.0, 2.0 * tol);
      EXPECT_LE(std::abs(std::hypot(c.x(), c.y()) - 1.5), seam.band_mm + l.radius + 1e-6);
      EXPECT_EQ(l.flags, kLeafOnExposedSurface);
      ASSERT_GE(l.tangents.count, 1);
      EXPECT_GT(l.tangents.normal[0].z(), 0.99f);
    }
  }
}

TEST(SeamLeaves, CloseTheGrooveTheCutTreesLeave) {
  const CutBlock b;
  const TreeLeaves healthy_leaves = build_leaves(b.healthy, b.params);
  const TreeLeaves caries_leaves = build_leaves(b.caries, b.params);
  const SphereTree healthy = build_tree(healthy_leaves, b.params.branching);
  const SphereTree caries = build_tree(caries_leaves, b.params.branching);
  const auto border = [&](const Vec3& x) { return b.lesion.distance(x); };
  const std::vector<const SphereTree*> cut{&healthy, &caries};
  const Deviation before = measure_seam_deviation(cut, b.mesh, b.object, border, 0.5, 20000);

  const auto parts = build_seam_leaves(b.object, std::span<const LesionShape>(&b.lesion, 1), b.params);
  TreeLeaves healthy_seamed = healthy_leaves;
  TreeLeaves caries_seamed = caries_leaves;
  add_seam_leaves(healthy_seamed, parts[0], b.object, std::span<const LesionShape>(&b.lesion, 1), b.params);
  add_seam_leaves(caries_seamed, parts[1], b.object, std::span<const LesionShape>(&b.lesion, 1), b.params);
  const SphereTree healthy2 = build_tree(healthy_seamed, b.params.branching);
  const SphereTree caries2 = build_tree(caries_seamed, b.params.branching);
  EXPECT_EQ(check_tree(healthy2, 1e-3), "");
  EXPECT_EQ(check_tree(caries2, 1e-3), "");
  EXPECT_GT(healthy2.leaf_count(), healthy.leaf_count());
  const std::vector<const SphereTree*> closed{&healthy2, &caries2};
  const Deviation after = measure_seam_deviation(closed, b.mesh, b.object, border, 0.5, 20000);
  // The cut trees leave a groove at the edge; with the seam leaves the union follows the surface to
  // the tree's tolerance.
  EXPECT_GT(before.max, b.params.tolerance) << "the cut trees alone should leave a groove";
  EXPECT_LE(after.max, b.params.tolerance) << "seam p50 " << after.p50 << " p95 " << after.p95;
  EXPECT_LT(after.p95, before.p95);
}

TEST(SeamLeaves, JoinThePartsLeavesBeforeItsOneHierarchy) {
  const CutBlock b;
  const TreeLeaves own = build_leaves(b.healthy, b.params);
  const auto parts = build_seam_leaves(b.object, std::span<const LesionShape>(&b.lesion, 1), b.params);
  ASSERT_FALSE(parts[0].empty());
  TreeLeaves seamed = own;
  add_seam_leaves(seamed, parts[0], b.object, std::span<const LesionShape>(&b.lesion, 1), b.params);

  // The part's own leaves first, in their order, some shrunk where they poked out near the border
  // (none grown or moved), then the seam leaves as built.
  const std::size_t kept = seamed.leaves.size() - parts[0].size();
  ASSERT_LE(kept, own.leaves.size());
  std::size_t from = 0, shrunk = 0;
  for (std::size_t i = 0; i < kept; ++i) {
    while (from < own.leaves.size() && own.leaves[from].center != seamed.leaves[i].center) ++from;
    ASSERT_LT(from, own.leaves.size()) << "leaf " << i << " is not one of the part's own, in order";
    EXPECT_LE(seamed.leaves[i].radius, own.leaves[from].radius) << i;
    if (seamed.leaves[i].radius < own.leaves[from].radius) ++shrunk;
    ++from;
  }
  EXPECT_GT(shrunk, 0u) << "no leaf of the cut part pokes out at the border";
  for (std::size_t k = 0; k < parts[0].size(); ++k) {
    EXPECT_EQ(seamed.leaves[kept + k].center, parts[0][k].center) << k;
    EXPECT_EQ(seamed.leaves[kept + k].radius, parts[0][k].radius) << k;
  }

  // The tree is built once over them all: leaf i is seamed leaf i.
  const SphereTree tree = build_tree(seamed, b.params.branching);
  ASSERT_EQ(tree.leaf_count(), seamed.leaves.size());
  EXPECT_EQ(check_tree(tree, 1e-3), "");
  for (std::size_t i = 0; i < seamed.leaves.size(); ++i) {
    EXPECT_EQ(tree.nodes[tree.leaf_nodes[i]].center, seamed.leaves[i].center) << i;
    EXPECT_EQ(tree.nodes[tree.leaf_nodes[i]].radius, seamed.leaves[i].radius) << i;
  }
}

}  // namespace
}  // namespace cariesim
