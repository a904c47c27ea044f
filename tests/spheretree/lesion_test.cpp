#include "cariesim/spheretree/lesion.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim {
namespace {

using Kind = LesionShape::Kind;

// A lesion tilted off the axes, so that the local frame is exercised.
LesionShape tilted(Kind kind) {
  LesionShape s;
  s.kind = kind;
  s.center = Vec3(1.0, -2.0, 3.0);
  s.normal = Vec3(0.2, 0.3, 1.0).normalized();
  s.tangent = Vec3(1.0, 0.5, 0.0);
  s.size = 2.0;
  s.width = 0.8;
  s.depth = 1.5;
  if (kind == Kind::Polygon) s.polygon = LesionShape::triangle(2.5);
  return s;
}

// The lesion's frame (x tangent, y normal x tangent, z normal) as the shape defines it.
Mat3 frame_of(const LesionShape& s) {
  const Vec3 z = s.normal.normalized();
  const Vec3 x = (s.tangent - s.tangent.dot(z) * z).normalized();
  Mat3 f;
  f << x, z.cross(x), z;
  return f;
}

class EveryKind : public ::testing::TestWithParam<Kind> {};

TEST(LesionKind, NamesRoundTrip) {
  for (Kind k : {Kind::Disk, Kind::Stripe, Kind::Polygon, Kind::InvertedCone, Kind::Ellipsoid}) {
    Kind parsed{};
    ASSERT_TRUE(parse_lesion_kind(lesion_kind_name(k), parsed)) << lesion_kind_name(k);
    EXPECT_EQ(parsed, k);
  }
  EXPECT_EQ(lesion_kind_name(Kind::InvertedCone), "inverted-cone");
  Kind k{};
  EXPECT_TRUE(parse_lesion_kind("circle", k));
  EXPECT_EQ(k, Kind::Disk);
  EXPECT_FALSE(parse_lesion_kind("blob", k));
  EXPECT_FALSE(parse_lesion_kind("", k));
}

TEST(LesionShape, PolygonHelpersHaveTheRequestedSides) {
  const auto square = LesionShape::square(60.0);
  ASSERT_EQ(square.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR((square[i] - square[(i + 1) % 4]).norm(), 60.0, 1e-9);
  const auto tri = LesionShape::triangle(60.0);
  ASSERT_EQ(tri.size(), 3u);
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR((tri[i] - tri[(i + 1) % 3]).norm(), 60.0, 1e-9);
    centroid += tri[i] / 3.0;
  }
  EXPECT_LT(centroid.norm(), 1e-9);
  // Counter-clockwise: positive signed area.
  const Eigen::Vector2d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
  EXPECT_GT(e1.x() * e2.y() - e1.y() * e2.x(), 0.0);
}

TEST(LesionShape, DiskClosedForm) {
  LesionShape s;  // disk at the origin, normal +z, diameter 2, depth 1.5
  EXPECT_NEAR(s.distance(Vec3(0, 0, -0.75)), -0.75, 1e-12);   // mid-depth on the axis: 0.75 to the bottom
  EXPECT_NEAR(s.distance(Vec3(0.9, 0, -0.75)), -0.1, 1e-12);  // near the wall
  EXPECT_NEAR(s.distance(Vec3(1.3, 0, -0.75)), 0.3, 1e-12);   // outside the wall
  EXPECT_NEAR(s.distance(Vec3(0, 0, -2.0)), 0.5, 1e-12);      // below the flat bottom
  EXPECT_NEAR(s.distance(Vec3(1.3, 0, -1.9)), 0.5, 1e-12);    // off the bottom rim (0.3, 0.4)
  EXPECT_LT(s.distance(Vec3(0, 0, 1.4)), 0.0);                // above the surface
}

TEST(LesionShape, StripeClosedForm) {
  LesionShape s;
  s.kind = Kind::Stripe;
  s.size = 4.0;  // length along x, rounded ends
  s.width = 1.0;
  s.depth = 1.0;
  EXPECT_NEAR(s.distance(Vec3(0, 0.0, -0.2)), -0.5, 1e-12);    // on the axis: half the width to the sides
  EXPECT_NEAR(s.distance(Vec3(1.0, 0.3, -0.5)), -0.2, 1e-12);  // 0.2 from the long side
  EXPECT_NEAR(s.distance(Vec3(2.2, 0.0, -0.5)), 0.2, 1e-12);   // 0.2 past the rounded end (x = 2)
  EXPECT_NEAR(s.distance(Vec3(1.5 + 0.6 * std::cos(0.7), 0.6 * std::sin(0.7), -0.5)), 0.1, 1e-12);
}

TEST(LesionShape, InvertedConeClosedForm) {
  LesionShape s;
  s.kind = Kind::InvertedCone;
  s.size = 2.0;
  s.depth = 1.0;  // 45 degree flank from (1, 0) to the apex (0, -1)
  EXPECT_NEAR(s.distance(Vec3(0, 0, -1.0)), 0.0, 1e-12);
  EXPECT_NEAR(s.distance(Vec3(0, 0, -1.5)), 0.5, 1e-12);
  EXPECT_NEAR(s.distance(Vec3(1.0, 0, -1.0)), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(s.distance(Vec3(0.0, 0.2, -0.5)), -0.3 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(s.distance(Vec3(1.2, 0, 0.5)), 0.2, 1e-12);  // above the surface it is a cylinder
}

TEST(LesionShape, EllipsoidClosedForm) {
  LesionShape s;
  s.kind = Kind::Ellipsoid;
  s.size = 4.0;   // semi-axis 2 along x
  s.width = 2.0;  // semi-axis 1 along y
  s.depth = 0.5;  // semi-axis 0.5 along z
  EXPECT_NEAR(s.distance(Vec3(0, 0, 0)), -0.5, 1e-9);
  EXPECT_NEAR(s.distance(Vec3(3, 0, 0)), 1.0, 1e-9);
  EXPECT_NEAR(s.distance(Vec3(0, 1.25, 0)), 0.25, 1e-9);
  EXPECT_NEAR(s.distance(Vec3(0, 0, -0.8)), 0.3, 1e-9);
  // On the surface (parametric) the distance vanishes.
  for (double t = 0.1; t < 3.0; t += 0.37) {
    const Vec3 p(2.0 * std::cos(t) * std::cos(0.4), 1.0 * std::sin(t) * std::cos(0.4), 0.5 * std::sin(0.4));
    EXPECT_NEAR(s.distance(p), 0.0, 1e-9) << t;
  }
}

// Every shape: its distance is a true distance (projecting a point along the gradient by the
// distance lands on the zero set), it reaches `depth` below the centre and at least `depth` above.
TEST_P(EveryKind, IsADistanceAndSpansTheDepth) {
  const LesionShape s = tilted(GetParam());
  const Mat3 f = frame_of(s);
  const Vec3 n = f.col(2);
  EXPECT_LT(s.distance(s.center), 0.0);
  EXPECT_LT(s.distance(s.center + 0.99 * s.depth * n), 0.0) << "must extend above the surface";
  EXPECT_LT(s.distance(s.center - 0.9 * s.depth * n), 0.0);
  EXPECT_GT(s.distance(s.center - 1.1 * s.depth * n), 0.0);

  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  int good = 0, total = 0;
  for (int i = 0; i < 400; ++i) {
    const Vec3 p = s.center + Vec3(u(rng), u(rng), u(rng));
    const double d = s.distance(p);
    ASSERT_TRUE(std::isfinite(d));
    const double h = 1e-6;
    Vec3 g;
    for (int a = 0; a < 3; ++a) {
      Vec3 e = Vec3::Zero();
      e[a] = h;
      g[a] = (s.distance(p + e) - s.distance(p - e)) / (2 * h);
    }
    // Away from the medial axis |grad d| = 1 and one step along it reaches the surface.
    if (std::abs(g.norm() - 1.0) > 1e-3) continue;
    ++total;
    if (std::abs(s.distance(p - d * g)) < 1e-4 * std::max(1.0, std::abs(d))) ++good;
  }
  EXPECT_GT(total, 300);
  EXPECT_EQ(good, total);
}

TEST_P(EveryKind, LevelSetFollowsTheAnalyticDistance) {
  const LesionShape s = tilted(GetParam());
  const LevelSet ls = s.to_level_set(0.05, 0.25);
  ASSERT_FALSE(ls.empty());
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  int checked = 0;
  for (int i = 0; i < 20000 && checked < 300; ++i) {
    const Vec3 p = s.center + Vec3(u(rng), u(rng), u(rng));
    const double d = s.distance(p);
    if (std::abs(d) > 0.15) continue;
    ++checked;
    // Trilinear interpolation of exact samples: within a fraction of a voxel (corners are worst).
    EXPECT_NEAR(ls.distance(p), d, 0.02) << p.transpose();
  }
  EXPECT_GT(checked, 100);
  // Deep inside reads -band (every tilted shape is more than 0.25 mm thick at mid-depth), far
  // outside +band.
  const Vec3 mid_depth = s.center - 0.5 * s.depth * frame_of(s).col(2);
  ASSERT_LT(s.distance(mid_depth), -0.25);
  EXPECT_NEAR(ls.distance(mid_depth), -0.25, 1e-6);
  EXPECT_NEAR(ls.distance(s.center + Vec3(10, 10, 10)), 0.25, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Lesion, EveryKind,
                         ::testing::Values(Kind::Disk, Kind::Stripe, Kind::Polygon, Kind::InvertedCone,
                                           Kind::Ellipsoid),
                         [](const auto& info) {
                           std::string name(lesion_kind_name(info.param));
                           for (char& c : name) {
                             if (c == '-') c = '_';
                           }
                           return name;
                         });

TEST(LesionShape, BadShapesAreRejected) {
  const auto throws_with = [](const LesionShape& s, const std::string& what) {
    try {
      (void)s.to_level_set(0.05, 0.25);
    } catch (const Error& e) {
      return std::string(e.what()).find(what) != std::string::npos;
    }
    return false;
  };
  LesionShape s;
  s.depth = 0.0;
  EXPECT_TRUE(throws_with(s, "depth"));
  s = LesionShape{};
  s.size = -1.0;
  EXPECT_TRUE(throws_with(s, "size"));
  s = LesionShape{};
  s.kind = Kind::Stripe;
  s.width = std::nan("");
  EXPECT_TRUE(throws_with(s, "width"));
  s = LesionShape{};
  s.kind = Kind::Polygon;
  s.polygon = {{0, 0}, {1, 0}};
  EXPECT_TRUE(throws_with(s, "3 vertices"));
  s = LesionShape{};
  s.normal = Vec3::Zero();
  EXPECT_TRUE(throws_with(s, "normal"));
  EXPECT_THROW((void)LesionShape{}.to_level_set(0.0, 0.25), Error);
  EXPECT_THROW((void)LesionShape{}.to_level_set(0.05, 0.01), Error);
}

}  // namespace
}  // namespace cariesim
