// nearest_crossing: where a line meets a mesh nearest its origin, on either side, through either
// winding; no crossing beyond the range or in a triangle's plane; hostile lines refused.
#include "cariesim/geometry/ray_cast.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/procedural.hpp"

namespace cariesim {
namespace {

// A 2 x 2 x 2 mm box: x and y in [-1, 1], z in [-2, 0] (top face at z = 0).
TriangleMesh box() { return make_cuboid(Vec3(2.0, 2.0, 2.0)); }

TEST(NearestCrossing, FromInsideTheNearerFaceOnEitherSide) {
  const TriangleMesh mesh = box();
  // 0.5 mm below the top, 1.5 mm above the bottom.
  const Vec3 inside(0.2, 0.3, -0.5);
  const std::optional<double> up = nearest_crossing(mesh, inside, Vec3::UnitZ(), 5.0);
  ASSERT_TRUE(up.has_value());
  EXPECT_NEAR(*up, 0.5, 1e-12);
  const std::optional<double> down = nearest_crossing(mesh, inside, -Vec3::UnitZ(), 5.0);
  ASSERT_TRUE(down.has_value());
  EXPECT_NEAR(*down, -0.5, 1e-12);
}

TEST(NearestCrossing, BehindTheOriginAndWithinTheRangeOnly) {
  const TriangleMesh mesh = box();
  // Above the top face, the line along its outward normal: the face lies behind (t < 0).
  const Vec3 above(0.2, 0.3, 0.25);
  const std::optional<double> t = nearest_crossing(mesh, above, Vec3::UnitZ(), 1.0);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, -0.25, 1e-12);
  EXPECT_FALSE(nearest_crossing(mesh, above, Vec3::UnitZ(), 0.2).has_value());
  EXPECT_TRUE(nearest_crossing(mesh, above, Vec3::UnitZ(), 0.25).has_value());
  // t counts in units of the direction.
  const std::optional<double> half = nearest_crossing(mesh, above, Vec3(0.0, 0.0, 2.0), 1.0);
  ASSERT_TRUE(half.has_value());
  EXPECT_NEAR(*half, -0.125, 1e-12);
  // A line beside the box meets nothing.
  EXPECT_FALSE(nearest_crossing(mesh, Vec3(5.0, 5.0, 0.0), Vec3::UnitZ(), 100.0).has_value());
  EXPECT_FALSE(nearest_crossing(TriangleMesh{}, above, Vec3::UnitZ(), 100.0).has_value());
}

TEST(NearestCrossing, TrianglesOfEitherWinding) {
  TriangleMesh flipped = box();
  for (auto& tri : flipped.triangles) std::swap(tri[1], tri[2]);
  const Vec3 inside(-0.4, 0.1, -0.75);
  const std::optional<double> t = nearest_crossing(flipped, inside, Vec3::UnitZ(), 5.0);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.75, 1e-12);
}

TEST(NearestCrossing, ThroughAnEdgeOrACornerTrianglesShare) {
  // A unit square in z = 0 cut along its diagonal from (0, 0) to (1, 1).
  TriangleMesh square;
  square.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(1, 1, 0), Vec3f(0, 1, 0)};
  square.triangles = {{0, 1, 2}, {0, 2, 3}};
  for (const Vec3& at : {Vec3(0.5, 0.5, 0.0), Vec3(0.0, 0.0, 0.0), Vec3(1.0, 1.0, 0.0)}) {
    const std::optional<double> t = nearest_crossing(square, at + Vec3(0, 0, 0.3), Vec3::UnitZ(), 1.0);
    ASSERT_TRUE(t.has_value()) << "the line through (" << at.transpose() << ") slips through";
    EXPECT_NEAR(*t, -0.3, 1e-12);
  }
}

TEST(NearestCrossing, ALineInATrianglesPlaneDoesNotCrossIt) {
  TriangleMesh sheet;
  sheet.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)};
  sheet.triangles = {{0, 1, 2}};
  EXPECT_FALSE(nearest_crossing(sheet, Vec3(-1.0, 0.25, 0.0), Vec3::UnitX(), 10.0).has_value());
  const std::optional<double> t = nearest_crossing(sheet, Vec3(0.25, 0.25, 1.0), -Vec3::UnitZ(), 10.0);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 1.0, 1e-12);
}

TEST(NearestCrossing, RefusesHostileLines) {
  const TriangleMesh mesh = box();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_THROW((void)nearest_crossing(mesh, Vec3(nan, 0, 0), Vec3::UnitZ(), 1.0), Error);
  EXPECT_THROW((void)nearest_crossing(mesh, Vec3::Zero(), Vec3::Zero(), 1.0), Error);
  EXPECT_THROW((void)nearest_crossing(mesh, Vec3::Zero(), Vec3(0, inf, 1), 1.0), Error);
  EXPECT_THROW((void)nearest_crossing(mesh, Vec3::Zero(), Vec3::UnitZ(), -1.0), Error);
  EXPECT_THROW((void)nearest_crossing(mesh, Vec3::Zero(), Vec3::UnitZ(), nan), Error);
  // An infinite range is every crossing.
  EXPECT_TRUE(nearest_crossing(mesh, Vec3(0.2, 0.3, 7.0), Vec3::UnitZ(), inf).has_value());
}

}  // namespace
}  // namespace cariesim
