#include "cariesim/spheretree/level_set.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <thread>
#include <vector>

#include "cariesim/common/error.hpp"
#include "spheretree/test_shapes.hpp"

namespace cariesim {
namespace {

using testing::make_box;
using testing::make_icosphere;

constexpr double kVoxel = 0.05;  // mm
constexpr double kBand = 0.25;   // mm

TEST(LevelSet, BoxDistancesAreExactOnFacesAndSignedInside) {
  const LevelSet box = LevelSet::from_mesh(make_box(Vec3(-2, -2, -1), Vec3(2, 2, 1)), kVoxel, kBand);
  EXPECT_NEAR(box.distance(Vec3(0.3, 0.2, 1.0)), 0.0, 1e-4);
  EXPECT_NEAR(box.distance(Vec3(0.3, 0.2, 1.1)), 0.1, 1e-4);
  EXPECT_NEAR(box.distance(Vec3(0.3, 0.2, 0.9)), -0.1, 1e-4);
  EXPECT_NEAR(box.distance(Vec3(-1.87, 0.0, 0.0)), -0.13, 1e-4);
  // Deep inside and far outside the value saturates at the band.
  EXPECT_NEAR(box.distance(Vec3::Zero()), -kBand, 1e-6);
  EXPECT_NEAR(box.distance(Vec3(0, 0, 5)), kBand, 1e-6);
  EXPECT_DOUBLE_EQ(box.voxel_size(), kVoxel);
  EXPECT_DOUBLE_EQ(box.half_band(), kBand);
  EXPECT_FALSE(box.empty());
}

TEST(LevelSet, SphereDistanceAndGradientMatchTheClosedForm) {
  const double r = 3.0;
  const LevelSet ball = LevelSet::from_mesh(make_icosphere(r, 5), kVoxel, kBand);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> offset(-0.15, 0.15);
  for (int i = 0; i < 200; ++i) {
    const Vec3 dir = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const double d = offset(rng);
    const Vec3 p = (r + d) * dir;
    // The icosphere's facets sit at most ~r * (1 - cos(edge/2r)) inside the true sphere.
    EXPECT_NEAR(ball.distance(p), d, 0.006) << p.transpose();
    EXPECT_GT(ball.gradient(p).dot(dir), 0.995) << p.transpose();
  }
}

TEST(LevelSet, BoundsHoldTheSurface) {
  const LevelSet box = LevelSet::from_mesh(make_box(Vec3(1, 2, 3), Vec3(4, 5, 6)), kVoxel, kBand);
  const Eigen::AlignedBox3d b = box.bounds();
  EXPECT_TRUE(b.contains(Vec3(1, 2, 3)));
  EXPECT_TRUE(b.contains(Vec3(4, 5, 6)));
  EXPECT_LT((b.min() - Vec3(1, 2, 3)).cwiseAbs().maxCoeff(), kBand + 2 * kVoxel);
  EXPECT_LT((b.max() - Vec3(4, 5, 6)).cwiseAbs().maxCoeff(), kBand + 2 * kVoxel);
}

TEST(LevelSet, ToMeshIsClosedOutwardAndOnTheSurface) {
  const double r = 2.0;
  const LevelSet ball = LevelSet::from_mesh(make_icosphere(r, 5), kVoxel, kBand);
  const TriangleMesh mesh = ball.to_mesh();
  ASSERT_FALSE(mesh.triangles.empty());
  const double expected = 4.0 / 3.0 * std::numbers::pi * r * r * r;
  EXPECT_NEAR(mesh.volume(), expected, 0.01 * expected);
  for (const Vec3f& v : mesh.vertices) EXPECT_NEAR(v.cast<double>().norm(), r, 0.01);
  // Adaptive meshing keeps the shape (within a few percent of its volume) with fewer triangles.
  const TriangleMesh coarse = ball.to_mesh(0.5);
  EXPECT_LT(coarse.triangles.size(), mesh.triangles.size());
  EXPECT_NEAR(coarse.volume(), expected, 0.04 * expected);
}

// Volumes of CSG results, measured on their display meshes, against the closed form.
TEST(LevelSet, CsgOfTwoBoxesHasTheExpectedVolumes) {
  const LevelSet a = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(2, 2, 2)), kVoxel, kBand);
  const LevelSet b = LevelSet::from_mesh(make_box(Vec3(1, 0.5, 0.5), Vec3(3, 1.5, 1.5)), kVoxel, kBand);
  EXPECT_NEAR(a.united(b).to_mesh().volume(), 8.0 + 1.0, 0.05);
  EXPECT_NEAR(a.intersection(b).to_mesh().volume(), 1.0, 0.05);
  EXPECT_NEAR(a.difference(b).to_mesh().volume(), 7.0, 0.05);
  // Pointwise: min / max / max(a, -b).
  const Vec3 p(1.5, 1.0, 1.0);
  EXPECT_NEAR(a.intersection(b).distance(p), std::max(a.distance(p), b.distance(p)), 1e-5);
  EXPECT_NEAR(a.difference(b).distance(p), std::max(a.distance(p), -b.distance(p)), 1e-5);
  EXPECT_NEAR(a.united(b).distance(p), std::min(a.distance(p), b.distance(p)), 1e-5);
}

TEST(LevelSet, CsgRebuildsAnOperandOnOtherVoxels) {
  const LevelSet a = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(2, 2, 2)), kVoxel, kBand);
  const LevelSet b = LevelSet::from_mesh(make_box(Vec3(1, 0.5, 0.5), Vec3(3, 1.5, 1.5)), 0.07, 0.35);
  const LevelSet diff = a.difference(b);
  EXPECT_DOUBLE_EQ(diff.voxel_size(), kVoxel);
  EXPECT_NEAR(diff.to_mesh().volume(), 7.0, 0.08);
  EXPECT_NEAR(diff.distance(Vec3(1.0, 1.0, 1.0)), 0.0, 0.01);  // on the cut wall
}

TEST(LevelSet, CsgWithAnEmptyOperand) {
  const LevelSet a = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(1, 1, 1)), kVoxel, kBand);
  const LevelSet none;
  EXPECT_TRUE(none.empty());
  EXPECT_TRUE(a.intersection(none).empty());
  EXPECT_NEAR(a.difference(none).to_mesh().volume(), 1.0, 0.02);
  EXPECT_NEAR(none.united(a).to_mesh().volume(), 1.0, 0.02);
  EXPECT_TRUE(none.to_mesh().triangles.empty());
  EXPECT_EQ(none.distance(Vec3::Zero()), std::numeric_limits<double>::infinity());
}

TEST(LevelSet, CopiesAreIndependentAndMovesLeaveAnEmptySet) {
  LevelSet a = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(1, 1, 1)), kVoxel, kBand);
  LevelSet copy = a;
  a = LevelSet::from_mesh(make_box(Vec3(0, 0, 0), Vec3(2, 2, 2)), kVoxel, kBand);
  EXPECT_NEAR(copy.distance(Vec3(1.0, 0.5, 0.5)), 0.0, 1e-4);
  EXPECT_NEAR(a.distance(Vec3(1.0, 0.5, 0.5)), -kBand, 1e-4);
  LevelSet moved = std::move(copy);
  EXPECT_FALSE(moved.empty());
  EXPECT_TRUE(copy.empty());  // NOLINT(bugprone-use-after-move): a moved-from set is empty
}

TEST(LevelSet, ConstQueriesAreThreadSafe) {
  const LevelSet ball = LevelSet::from_mesh(make_icosphere(2.0, 4), kVoxel, kBand);
  std::vector<Vec3> points;
  for (int i = 0; i < 2000; ++i)
    points.emplace_back(std::sin(i) * 2.1, std::cos(i * 0.7) * 2.0, std::sin(i * 1.3) * 1.9);
  std::vector<double> serial;
  for (const Vec3& p : points) serial.push_back(ball.distance(p));
  std::vector<std::vector<double>> parallel(4);
  std::vector<std::thread> threads;
  for (auto& out : parallel) {
    threads.emplace_back([&] {
      for (const Vec3& p : points) out.push_back(ball.distance(p));
    });
  }
  for (auto& t : threads) t.join();
  for (const auto& out : parallel) EXPECT_EQ(out, serial);
}

TEST(LevelSet, BadInputIsRejectedWithAReason) {
  const TriangleMesh box = make_box(Vec3(0, 0, 0), Vec3(1, 1, 1));
  const auto message = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message([&] { (void)LevelSet::from_mesh(TriangleMesh{}, kVoxel, kBand); }).find("no triangles"),
            std::string::npos);
  EXPECT_NE(message([&] { (void)LevelSet::from_mesh(box, 0.0, kBand); }).find("voxel size"),
            std::string::npos);
  EXPECT_NE(message([&] { (void)LevelSet::from_mesh(box, kVoxel, 0.01); }).find("half band"),
            std::string::npos);
  TriangleMesh nan_mesh = box;
  nan_mesh.vertices[3].x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(message([&] { (void)LevelSet::from_mesh(nan_mesh, kVoxel, kBand); }).find("vertex 3"),
            std::string::npos);
  TriangleMesh bad_index = box;
  bad_index.triangles[5][1] = 99;
  EXPECT_NE(message([&] { (void)LevelSet::from_mesh(bad_index, kVoxel, kBand); }).find("triangle 5"),
            std::string::npos);
}

}  // namespace
}  // namespace cariesim
