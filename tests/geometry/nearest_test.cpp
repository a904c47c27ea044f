// Nearest points on a mesh with Phong's interpolated normal (geometry/nearest.hpp), the surface force
// shading turns the force to (docs/step.md, "Force shading").
#include "cariesim/geometry/nearest.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cariesim/common/error.hpp"
#include "geometry/mesh_test_util.hpp"

namespace cariesim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

TEST(MeshNearest, FindsThePointAndTheInterpolatedNormalOfASphere) {
  const Vec3 centre(1.0, -2.0, 3.0);
  const TriangleMesh sphere = test::uv_sphere(centre, 2.0, 48, 24);
  const MeshNearest nearest(sphere, 0.2);
  // Points 0.05 mm outside the sphere all round: the mesh point within the facets' sagitta of the
  // sphere, the normal within a degree of the radial direction (a facet's own normal is up to 3.75
  // degrees off at 48 segments).
  int checked = 0;
  for (int i = 1; i < 12; ++i)
    for (int j = 0; j < 24; ++j) {
      const double theta = 3.14159265358979 * (i + 0.37) / 12.0,
                   phi = 2.0 * 3.14159265358979 * (j + 0.21) / 24.0;
      const Vec3 dir(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      MeshNearest::Hit hit;
      ASSERT_TRUE(nearest.nearest(centre + 2.05 * dir, 0.2, &hit)) << i << " " << j;
      EXPECT_NEAR((hit.point - centre).norm(), 2.0, 0.02);
      EXPECT_NEAR(hit.distance, (hit.point - (centre + 2.05 * dir)).norm(), 1e-12);
      EXPECT_LT(std::acos(std::min(1.0, hit.normal.dot(dir))), 1.0 * kDeg) << i << " " << j;
      EXPECT_NEAR(hit.normal.norm(), 1.0, 1e-12);
      ++checked;
    }
  EXPECT_EQ(checked, 11 * 24);
}

TEST(MeshNearest, TheNormalTurnsSmoothlyAcrossTheFacets) {
  // Along a line of points 0.01 mm apart over the sphere's equator, the interpolated normal turns by
  // about the arc between them, never by a facet's jump (7.5 degrees at 48 segments).
  const TriangleMesh sphere = test::uv_sphere(Vec3::Zero(), 2.0, 48, 24);
  const MeshNearest nearest(sphere, 0.2);
  Vec3 last = Vec3::Zero();
  double largest = 0.0;  // degrees between neighbouring samples
  for (int k = 0; k <= 200; ++k) {
    const double phi = 0.5 * k / 200.0;  // rad: about 4 facets
    MeshNearest::Hit hit;
    ASSERT_TRUE(nearest.nearest(2.02 * Vec3(std::cos(phi), std::sin(phi), 0.01), 0.1, &hit)) << k;
    if (k > 0) largest = std::max(largest, std::acos(std::min(1.0, hit.normal.dot(last))) / kDeg);
    last = hit.normal;
  }
  EXPECT_LT(largest, 0.5);
}

TEST(MeshNearest, NothingWithinReachOrABadPointFindsNothing) {
  const MeshNearest nearest(test::unit_cube(), 0.25);
  MeshNearest::Hit hit;
  EXPECT_FALSE(nearest.nearest(Vec3(0.5, 0.5, 1.5), 0.4, &hit));  // 0.5 mm above the top
  EXPECT_TRUE(nearest.nearest(Vec3(0.5, 0.5, 1.3), 0.4, &hit));
  EXPECT_NEAR(hit.point.z(), 1.0, 1e-6);
  EXPECT_FALSE(nearest.nearest(Vec3(40.0, 0.5, 0.5), 0.4, &hit));  // far outside the grid's box
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(nearest.nearest(Vec3(nan, 0.5, 0.5), 0.4, &hit));
  EXPECT_FALSE(nearest.nearest(Vec3(0.5, 0.5, 1.0), -1.0, &hit));
  const MeshNearest none;
  EXPECT_TRUE(none.empty());
  EXPECT_FALSE(none.nearest(Vec3::Zero(), 1.0, &hit));
  EXPECT_THROW(MeshNearest(test::unit_cube(), 0.0), Error);
  EXPECT_THROW(MeshNearest(test::unit_cube(), std::numeric_limits<double>::quiet_NaN()), Error);
}

}  // namespace
}  // namespace cariesim
