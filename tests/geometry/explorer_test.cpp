#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/procedural.hpp"

namespace cariesim {
namespace {

// The explorer's centre line and radius as docs/tool-frame.md describes them, written out here
// independently of the implementation: arc length s from the tip.
struct Reference {
  ExplorerParams p;
  double ferrule = 6.0;  // mm, the handle's conical start

  [[nodiscard]] double s1() const { return p.tip_segment; }
  [[nodiscard]] double s2() const { return s1() + p.bend_radius * p.bend_angle; }
  [[nodiscard]] double s3() const { return s2() + p.shank_length; }
  [[nodiscard]] double s4() const { return s3() + p.handle_length; }

  [[nodiscard]] Vec3 point(double s) const {
    if (s <= s1()) return {0, 0, s};
    const double r = p.bend_radius;
    if (s <= s2()) {
      const double phi = (s - s1()) / r;
      return {r - r * std::cos(phi), 0, s1() + r * std::sin(phi)};
    }
    const Vec3 end(r - r * std::cos(p.bend_angle), 0, s1() + r * std::sin(p.bend_angle));
    return end + (s - s2()) * Vec3(std::sin(p.bend_angle), 0, std::cos(p.bend_angle));
  }
  [[nodiscard]] Vec3 tangent(double s) const {
    const double phi = std::clamp((s - s1()) / p.bend_radius, 0.0, p.bend_angle);
    return {std::sin(phi), 0, std::cos(phi)};
  }
  [[nodiscard]] double radius(double s) const {
    if (s <= s2()) return p.tip_radius + (p.working_end_radius - p.tip_radius) * s / s2();
    if (s <= s3())
      return p.working_end_radius + (p.shank_radius - p.working_end_radius) * (s - s2()) / p.shank_length;
    return p.shank_radius + (p.handle_radius - p.shank_radius) * std::min((s - s3()) / ferrule, 1.0);
  }
  // Arc length of the centre-line point nearest to c (the chain's centres lie on the line).
  [[nodiscard]] double arc_length_of(const Vec3& c) const {
    double best = 0.0;
    double best_d = 1e9;
    for (double s = 0.0; s <= s4(); s += 0.01) {
      const double d = (point(s) - c).norm();
      if (d < best_d) {
        best_d = d;
        best = s;
      }
    }
    for (double s = best - 0.01; s <= best + 0.01; s += 1e-5) {
      const double d = (point(s) - c).norm();
      if (d < best_d) {
        best_d = d;
        best = s;
      }
    }
    return best;
  }
};

TEST(ExplorerSpheres, TipSphereAtTheOriginAndTipSegmentOnPlusZ) {
  const ExplorerParams p;
  const auto spheres = make_explorer_spheres(p);
  ASSERT_FALSE(spheres.empty());
  EXPECT_EQ(spheres[0].center, Vec3::Zero());
  EXPECT_DOUBLE_EQ(spheres[0].radius, 0.05);
  EXPECT_EQ(spheres[0].segment, 0);
  int on_tip_segment = 0;
  for (const auto& s : spheres) {
    if (s.segment != 0) continue;
    ++on_tip_segment;
    EXPECT_DOUBLE_EQ(s.center.x(), 0.0);
    EXPECT_DOUBLE_EQ(s.center.y(), 0.0);
    EXPECT_GE(s.center.z(), 0.0);
    EXPECT_LE(s.center.z(), p.tip_segment);
  }
  EXPECT_GE(on_tip_segment, 10);
  std::cout << "explorer chain: " << spheres.size() << " spheres\n";
  EXPECT_LE(spheres.size(), 250u);
}

TEST(ExplorerSpheres, ChainIsOrderedConnectedAndBendsTowardPlusX) {
  const ExplorerParams p;
  const Reference ref{p};
  const auto spheres = make_explorer_spheres(p);
  double previous_s = -1.0;
  int previous_segment = 0;
  double length = 0.0;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const auto& s = spheres[i];
    // On the centre line, in the x-z plane, in order from the tip, with the right segment label.
    const double arc = ref.arc_length_of(s.center);
    EXPECT_LT((ref.point(arc) - s.center).norm(), 1e-5) << i;
    EXPECT_EQ(s.center.y(), 0.0) << i;
    EXPECT_GT(arc, previous_s) << i;
    EXPECT_GE(s.segment, previous_segment) << i;
    EXPECT_NEAR(s.radius, ref.radius(arc), 1e-6) << i;
    const int expected_segment = arc < ref.s1() - 1e-9   ? 0
                                 : arc < ref.s2() - 1e-9 ? 1
                                 : arc < ref.s3() - 1e-9 ? 2
                                                         : 3;
    EXPECT_EQ(s.segment, expected_segment) << i << " at s = " << arc;
    if (i > 0) {
      const double d = (s.center - spheres[i - 1].center).norm();
      EXPECT_LT(d, s.radius + spheres[i - 1].radius)
          << "spheres " << i - 1 << " and " << i << " do not overlap";
      length += d;
    }
    previous_s = arc;
    previous_segment = s.segment;
  }
  // All four parts present, the working end bends toward +x, and the last sphere ends the handle.
  EXPECT_EQ(spheres.back().segment, 3);
  for (const auto& s : spheres) EXPECT_GE(s.center.x(), -1e-9);
  const Vec3 dir = (spheres.back().center - spheres[spheres.size() - 2].center).normalized();
  EXPECT_NEAR(dir.x(), std::sin(p.bend_angle), 1e-6);
  EXPECT_NEAR(dir.z(), std::cos(p.bend_angle), 1e-6);
  EXPECT_NEAR(spheres.back().radius, p.handle_radius, 1e-9);
  // Total length: the centre line up to the handle's rounded end.
  EXPECT_NEAR(length + spheres.back().radius, ref.s4(), 0.05);
  EXPECT_GT(ref.s4(), 100.0);
  EXPECT_LT(ref.s4(), 200.0);
}

// Largest dip (mm) of the union of spheres below the ideal tube, per segment, measured along rays
// from the centre line in 16 directions around it, at 20 stations between consecutive centres.
std::array<double, 4> measured_scallop(const std::vector<ToolSphere>& spheres, const Reference& ref) {
  std::array<double, 4> worst{0, 0, 0, 0};
  for (std::size_t i = 0; i + 1 < spheres.size(); ++i) {
    const double a = ref.arc_length_of(spheres[i].center);
    const double b = ref.arc_length_of(spheres[i + 1].center);
    for (int k = 1; k < 20; ++k) {
      const double s = a + (b - a) * k / 20.0;
      const Vec3 c = ref.point(s);
      const Vec3 t = ref.tangent(s);
      const Vec3 u = Vec3::UnitY().cross(t);
      const double r = ref.radius(s);
      for (int j = 0; j < 16; ++j) {
        const double theta = 2 * std::numbers::pi * j / 16;
        const Vec3 n = std::cos(theta) * u + std::sin(theta) * Vec3::UnitY();
        double reach = 0.0;
        for (std::size_t m = (i >= 3 ? i - 3 : 0); m < std::min(spheres.size(), i + 5); ++m) {
          const Vec3 q = spheres[m].center - c;
          const double along = n.dot(q);
          const double disc = along * along - q.squaredNorm() + spheres[m].radius * spheres[m].radius;
          if (disc >= 0.0) reach = std::max(reach, along + std::sqrt(disc));
        }
        worst[spheres[i].segment] = std::max(worst[spheres[i].segment], r - std::min(reach, r));
      }
    }
  }
  return worst;
}

TEST(ExplorerSpheres, ScallopStaysWithinTheBounds) {
  const ExplorerParams p;
  const Reference ref{p};
  for (const double max_gap : {0.01, 0.005}) {
    const auto spheres = make_explorer_spheres(p, max_gap);
    const auto worst = measured_scallop(spheres, ref);
    std::cout << "max_gap " << max_gap << ": " << spheres.size() << " spheres, scallop tip " << worst[0]
              << " working end " << worst[1] << " shank " << worst[2] << " handle " << worst[3] << " mm\n";
    EXPECT_LE(worst[0], max_gap + 1e-5);
    EXPECT_LE(worst[1], max_gap + 1e-5);
    EXPECT_LE(worst[2], 0.05 + 1e-5);
    EXPECT_LE(worst[3], 0.5 + 1e-5);
    // The bound is used, not vastly undershot (so the chain stays short).
    EXPECT_GT(worst[1], 0.5 * max_gap);
  }
  EXPECT_GT(make_explorer_spheres(p, 0.005).size(), make_explorer_spheres(p, 0.01).size());
}

TEST(ExplorerSpheres, RejectsBadParameters) {
  ExplorerParams p;
  EXPECT_THROW((void)make_explorer_spheres(p, 0.0), Error);
  EXPECT_THROW((void)make_explorer_spheres(p, std::nan("")), Error);
  p.tip_radius = -0.05;
  EXPECT_THROW((void)make_explorer_spheres(p), Error);
  p = {};
  p.bend_angle = 4.0;
  EXPECT_THAT([&] { (void)make_explorer_spheres(p); },
              ::testing::ThrowsMessage<Error>(::testing::HasSubstr("bend_angle")));
  p = {};
  p.working_end_radius = 7.0;
  EXPECT_THROW((void)make_explorer_mesh(p), Error);
}

TEST(ExplorerMesh, ClosedTubeAlongTheChain) {
  const ExplorerParams p;
  const TriangleMesh mesh = make_explorer_mesh(p);
  TriangleMesh copy = mesh;
  MeshReport report;
  validate_mesh(copy, "explorer", &report);
  EXPECT_TRUE(report.watertight());
  EXPECT_EQ(report.components, 1u);
  EXPECT_EQ(report.self_intersections, 0u);
  EXPECT_FALSE(report.flipped);
  EXPECT_EQ(report.reoriented, 0u);
  EXPECT_GT(mesh.volume(), 0.0);
  std::cout << "explorer mesh: " << mesh.triangles.size() << " triangles\n";

  // The tip is a hemisphere of tip_radius around the origin, pointing along -z.
  double lowest_z = 1e9;
  for (const auto& v : mesh.vertices) {
    if (v.cast<double>().norm() < 2 * p.tip_radius) lowest_z = std::min(lowest_z, double(v.z()));
  }
  EXPECT_NEAR(lowest_z, -p.tip_radius, 1e-6);
  // Same extent as the sphere chain (which ends in the same rounded handle end).
  Eigen::AlignedBox3d chain;
  for (const auto& s : make_explorer_spheres(p)) {
    chain.extend(s.center + Vec3::Constant(s.radius));
    chain.extend(s.center - Vec3::Constant(s.radius));
  }
  EXPECT_LT((mesh.bounds().max() - chain.max()).cwiseAbs().maxCoeff(), 0.5);
  EXPECT_LT((mesh.bounds().min() - chain.min()).cwiseAbs().maxCoeff(), 0.5);
  // Volume of the handle dominates: between the bare cylinder and that cylinder plus the rest.
  const double handle = std::numbers::pi * p.handle_radius * p.handle_radius * (p.handle_length - 6.0);
  EXPECT_GT(mesh.volume(), 0.9 * handle);
  EXPECT_LT(mesh.volume(), 1.1 * handle + 200.0);
}

}  // namespace
}  // namespace cariesim
