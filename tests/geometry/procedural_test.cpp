#include "cariesim/geometry/procedural.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "cariesim/common/error.hpp"

namespace cariesim {
namespace {

MeshReport checked(const TriangleMesh& mesh, const char* what) {
  TriangleMesh copy = mesh;
  MeshReport report;
  validate_mesh(copy, what, &report);
  EXPECT_TRUE(report.watertight()) << what;
  EXPECT_EQ(report.self_intersections, 0u) << what;
  EXPECT_FALSE(report.flipped) << what << " was not wound outward";
  EXPECT_EQ(report.reoriented, 0u) << what;
  EXPECT_EQ(copy.triangles.size(), mesh.triangles.size()) << what << " needed repairs";
  return report;
}

TEST(Cuboid, TopFaceAtZeroAndExactVolume) {
  const Vec3 size(100, 100, 20);
  const TriangleMesh box = make_cuboid(size);
  const MeshReport report = checked(box, "cuboid");
  EXPECT_EQ(report.components, 1u);
  EXPECT_TRUE(box.bounds().min().isApprox(Vec3(-50, -50, -20)));
  EXPECT_TRUE(box.bounds().max().isApprox(Vec3(50, 50, 0)));
  EXPECT_NEAR(box.volume(), 100.0 * 100.0 * 20.0, 1e-6);
  EXPECT_NEAR(box.area(), 2 * (100.0 * 100.0 + 2 * 100.0 * 20.0), 1e-6);
  // Light: a handful of triangles per face.
  EXPECT_GE(box.triangles.size(), 12u);
  EXPECT_LE(box.triangles.size(), 200u);
  // Every vertex of the top face is exactly at z = 0.
  std::size_t top = 0;
  for (const auto& v : box.vertices) top += v.z() == 0.0f ? 1 : 0;
  EXPECT_GE(top, 4u);
}

TEST(Cuboid, ThinAndUnevenBoxesStayClosed) {
  for (const Vec3& size : {Vec3(1, 1, 1), Vec3(30, 2, 0.5), Vec3(0.2, 50, 7)}) {
    const TriangleMesh box = make_cuboid(size);
    checked(box, "cuboid");
    EXPECT_NEAR(box.volume(), size.prod(), 1e-6 * size.prod()) << size.transpose();
  }
}

TEST(Cuboid, RejectsBadSizes) {
  EXPECT_THROW((void)make_cuboid(Vec3(0, 1, 1)), Error);
  EXPECT_THROW((void)make_cuboid(Vec3(1, -1, 1)), Error);
  EXPECT_THROW((void)make_cuboid(Vec3(1, 1, std::numeric_limits<double>::infinity())), Error);
}

TEST(Gingiva, BandHangsBelowTheMarginAlongThePath) {
  GingivaParams g;
  g.path = {Vec3(-20, -5, 0.5), Vec3(-10, 0, 0.2), Vec3(0, 2, 0), Vec3(10, 0, 0.2), Vec3(20, -5, 0.5)};
  const TriangleMesh band = make_gingiva_band(g);
  const MeshReport report = checked(band, "gingiva");
  EXPECT_EQ(report.components, 1u);
  const auto box = band.bounds();
  std::cout << "gingiva " << band.triangles.size() << " triangles, bounds " << box.min().transpose() << " / "
            << box.max().transpose() << "\n";
  // The top follows the margin heights, the bottom is `height` lower, the ends are round.
  EXPECT_NEAR(box.max().z(), 0.5, 0.1);
  EXPECT_NEAR(box.min().z(), 0.0 - g.height, 0.1);
  EXPECT_NEAR(box.max().x(), 20.0 + 0.5 * g.width, 0.2);
  EXPECT_NEAR(box.min().x(), -20.0 - 0.5 * g.width, 0.2);
  EXPECT_NEAR(box.max().y(), 2.0 + 0.5 * g.width, 0.2);
  // Roughly width x height x length of the path.
  const double length = 2 * std::hypot(10.0, 5.0) + 2 * std::hypot(10.0, 2.0);
  EXPECT_NEAR(band.volume(), g.width * g.height * length, 0.25 * g.width * g.height * length);
}

TEST(Gingiva, SinglePointIsAPad) {
  GingivaParams g;
  g.path = {Vec3(3, 4, 1)};
  g.resolution = 0.4;
  const TriangleMesh pad = make_gingiva_band(g);
  checked(pad, "gingiva pad");
  EXPECT_NEAR(pad.bounds().center().x(), 3.0, 0.1);
  EXPECT_NEAR(pad.bounds().sizes().x(), g.width, 0.2);
}

TEST(Gingiva, RejectsBadInput) {
  GingivaParams g;
  EXPECT_THAT([&] { (void)make_gingiva_band(g); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("path")));
  g.path = {Vec3(0, 0, 0), Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0)};
  EXPECT_THAT([&] { (void)make_gingiva_band(g); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("point 1")));
  g.path = {Vec3(0, 0, 0), Vec3(10, 0, 0)};
  g.width = -1.0;
  EXPECT_THAT([&] { (void)make_gingiva_band(g); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("width")));
}

TEST(Tongue, FlattenedBodyOfTheGivenSize) {
  const TongueParams t;
  const TriangleMesh tongue = make_tongue(t);
  const MeshReport report = checked(tongue, "tongue");
  EXPECT_EQ(report.components, 1u);
  const auto box = tongue.bounds();
  EXPECT_NEAR(box.sizes().x(), t.length, 2.0 * t.resolution);
  EXPECT_NEAR(box.sizes().y(), t.width, 2.0 * t.resolution);
  EXPECT_NEAR(box.sizes().z(), t.height, 2.0 * t.resolution);
  EXPECT_LT(box.center().norm(), t.resolution);
  // Narrower toward the tip (+x) than at the back.
  auto width_near = [&](double x) {
    double lo = 0.0;
    double hi = 0.0;
    for (const auto& v : tongue.vertices) {
      if (std::abs(v.x() - x) < t.resolution) {
        lo = std::min(lo, double(v.y()));
        hi = std::max(hi, double(v.y()));
      }
    }
    return hi - lo;
  };
  EXPECT_LT(width_near(0.35 * t.length), 0.9 * width_near(-0.25 * t.length));
}

TEST(Tongue, RejectsBadSizes) {
  TongueParams t;
  t.height = 0.0;
  EXPECT_THAT([&] { (void)make_tongue(t); }, ::testing::ThrowsMessage<Error>(::testing::HasSubstr("height")));
}

}  // namespace
}  // namespace cariesim
