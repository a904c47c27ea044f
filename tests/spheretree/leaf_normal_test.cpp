// Leaf normals: each leaf knows the outward normal of the surface it is tangent to (compliant
// contacts in the haptic step push along it).
#include <gtest/gtest.h>

#include "cariesim/spheretree/build.hpp"
#include "spheretree/test_shapes.hpp"

namespace cariesim {
namespace {

TEST(LeafNormals, SurfaceLeavesPointRadiallyOutOfASphere) {
  const Vec3 center(1.0, -2.0, 0.5);
  const LevelSet shape = LevelSet::from_mesh(testing::make_icosphere(3.0, 4, center), 0.05, 0.3);
  for (TreeMode mode : {TreeMode::Tight, TreeMode::Octree}) {
    TreeParams params;
    params.mode = mode;
    params.tolerance = 0.03;
    const SphereTree tree = build_sphere_tree(shape, params);
    ASSERT_EQ(tree.leaf_normal.size(), tree.leaf_count());
    int checked = 0;
    for (std::size_t i = 0; i < tree.leaf_count(); ++i) {
      const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
      const Vec3 c = node.center.cast<double>();
      const Vec3 n = tree.leaf_normal[i].cast<double>();
      if (node.flags & kLeafInterior) {
        EXPECT_EQ(n.norm(), 0.0) << i;  // fillers have no surface
        continue;
      }
      EXPECT_NEAR(n.norm(), 1.0, 1e-5) << i;
      // The icosphere's facets tilt the normal a little from the exact radial direction.
      EXPECT_GT(n.dot((c - center).normalized()), 0.98) << i;
      ++checked;
    }
    EXPECT_GT(checked, 20);
  }
}

}  // namespace
}  // namespace cariesim
