// Leaf normals: each leaf knows the outward normal of the surface it is tangent to (compliant
// contacts in the haptic step push along it).
#include <gtest/gtest.h>

#include "cariesim/spheretree/build.hpp"
#include "spheretree/test_shapes.hpp"

namespace cariesim {
namespace {

TEST(LeafTangents, SurfaceLeavesPointRadiallyOutOfASphere) {
  const Vec3 center(1.0, -2.0, 0.5);
  const LevelSet shape = LevelSet::from_mesh(testing::make_icosphere(3.0, 4, center), 0.05, 0.3);
  for (TreeMode mode : {TreeMode::Tight, TreeMode::Octree}) {
    TreeParams params;
    params.mode = mode;
    params.tolerance = 0.03;
    const SphereTree tree = build_sphere_tree(shape, params);
    ASSERT_EQ(tree.leaf_tangents.size(), tree.leaf_count());
    int checked = 0;
    for (std::size_t i = 0; i < tree.leaf_count(); ++i) {
      const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
      const Vec3 c = node.center.cast<double>();
      const LeafTangents& t = tree.leaf_tangents[i];
      if (node.flags & kLeafInterior) {
        EXPECT_EQ(t.count, 0) << i;  // fillers have no surface
        continue;
      }
      ASSERT_EQ(t.count, 1) << i;  // a sphere touches a ball's surface once
      const Vec3 n = t.normal[0].cast<double>();
      EXPECT_NEAR(n.norm(), 1.0, 1e-5) << i;
      // The icosphere's facets tilt the normal a little from the exact radial direction.
      EXPECT_GT(n.dot((c - center).normalized()), 0.98) << i;
      ++checked;
    }
    EXPECT_GT(checked, 20);
  }
}

// A thin slab: spheres spanning it touch its top and its floor; one at an edge touches two faces.
TEST(LeafTangents, ThinLayerSpheresKnowBothFaces) {
  TriangleMesh slab = testing::make_box(Vec3(-4, -4, -0.5), Vec3(4, 4, 0.5));
  const LevelSet shape = LevelSet::from_mesh(slab, 0.05, 0.3);
  TreeParams params;
  params.tolerance = 0.02;
  params.max_radius = 2.0;
  const SphereTree tree = build_sphere_tree(shape, params);
  int both = 0, centre = 0;
  for (std::size_t i = 0; i < tree.leaf_count(); ++i) {
    const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
    const Vec3 c = node.center.cast<double>();
    if (std::abs(c.x()) > 3.0 || std::abs(c.y()) > 3.0 || node.radius < 0.45f) continue;
    ++centre;  // a sphere as thick as the slab, away from its edges
    const LeafTangents& t = tree.leaf_tangents[i];
    ASSERT_EQ(t.count, 2) << i;
    EXPECT_NEAR(std::abs(t.normal[0].z()), 1.0, 0.05);
    EXPECT_NEAR(t.normal[0].z() + t.normal[1].z(), 0.0, 0.1);  // one up, one down
    ++both;
  }
  EXPECT_GT(centre, 10);
  EXPECT_EQ(both, centre);
}

}  // namespace
}  // namespace cariesim
