// Soft-tissue dents (apps/viewer/soft_dent.cpp): penetration from a compliant contact's force, the
// displacement profile, and what is left alone.
#include "viewer/soft_dent.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace {

using cariesim::ContactReport;
using cariesim::Vec3;
using cariesim::Vec3f;
using cariesim::viewer::apply_dents;
using cariesim::viewer::Dent;
using cariesim::viewer::dent_from_contact;
using cariesim::viewer::dent_radius;

ContactReport contact(const Vec3& point, const Vec3& normal, double force) {
  ContactReport c{};
  c.point = point;
  c.normal = normal;
  c.force = force;
  return c;
}

// The penetration of a compliant contact is force / stiffness; the undeformed surface lies that far
// out along the normal from the tool's deepest point.
TEST(SoftDent, PenetrationIsForceOverStiffness) {
  Dent d;
  ASSERT_TRUE(dent_from_contact(contact(Vec3(1, 2, 3), Vec3(0, 0, 2), 0.6), 0.3, d));
  EXPECT_NEAR(d.depth, 2.0, 1e-12);
  EXPECT_TRUE(d.normal.isApprox(Vec3::UnitZ()));
  EXPECT_TRUE(d.surface.isApprox(Vec3(1, 2, 5)));
}

// Rigid tissue, no load, and garbage make no dent.
TEST(SoftDent, NoDentWithoutACompliantLoad) {
  Dent d;
  EXPECT_FALSE(dent_from_contact(contact(Vec3::Zero(), Vec3::UnitZ(), 1.0),
                                 std::numeric_limits<double>::infinity(), d));
  EXPECT_FALSE(dent_from_contact(contact(Vec3::Zero(), Vec3::UnitZ(), 0.0), 0.3, d));
  EXPECT_FALSE(dent_from_contact(contact(Vec3::Zero(), Vec3::UnitZ(), std::nan("")), 0.3, d));
  EXPECT_FALSE(dent_from_contact(contact(Vec3::Zero(), Vec3::Zero(), 1.0), 0.3, d));
  EXPECT_FALSE(dent_from_contact(contact(Vec3(std::nan(""), 0, 0), Vec3::UnitZ(), 1.0), 0.3, d));
}

// A flat grid pressed at its centre: the centre goes down by the depth, the push falls off with
// distance, vertices beyond the radius stay.
TEST(SoftDent, DisplacementFallsOffWithDistance) {
  std::vector<Vec3f> base;
  for (int i = -20; i <= 20; ++i) base.emplace_back(0.25f * i, 0.0f, 0.0f);
  const Dent dent{Vec3::Zero(), Vec3::UnitZ(), 0.5};
  std::vector<Vec3f> out(base.size());
  const std::size_t moved = apply_dents(base, std::span<const Dent>(&dent, 1), out);
  const double radius = dent_radius(0.5);
  std::size_t inside = 0;
  for (std::size_t i = 0; i < base.size(); ++i) {
    const double r = std::abs(base[i].x());
    EXPECT_FLOAT_EQ(out[i].x(), base[i].x()) << "vertices move along the normal only";
    if (r < radius) {
      ++inside;
      const double q = r * r / (radius * radius);
      EXPECT_NEAR(out[i].z(), -0.5 * (1 - q) * (1 - q), 1e-6);
    } else {
      EXPECT_EQ(out[i].z(), 0.0f);
    }
  }
  EXPECT_EQ(moved, inside);
  EXPECT_NEAR(out[20].z(), -0.5, 1e-6);
}

// Overlapping dents: each vertex takes the deepest push; no dents restores the base.
TEST(SoftDent, DeepestDentWinsAndNoneRestores) {
  const std::vector<Vec3f> base{Vec3f(0, 0, 0), Vec3f(1, 0, 0)};
  const std::vector<Dent> dents{{Vec3(0, 0, 0), Vec3::UnitZ(), 0.2}, {Vec3(1, 0, 0), Vec3::UnitZ(), 0.6}};
  std::vector<Vec3f> out(2);
  apply_dents(base, dents, out);
  const double r = 1.0 / dent_radius(0.6);
  EXPECT_NEAR(out[0].z(), -std::max(0.2, 0.6 * (1 - r * r) * (1 - r * r)), 1e-6);
  EXPECT_NEAR(out[1].z(), -0.6, 1e-6);
  EXPECT_EQ(apply_dents(base, {}, out), 0u);
  EXPECT_EQ(out[0], base[0]);
  EXPECT_EQ(out[1], base[1]);
}

}  // namespace
