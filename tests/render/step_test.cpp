// Closed-form and robustness checks of the sliding state (issue 3 acceptance).
#include "cariesim/render/step.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "render/render_support.hpp"
#include "render/state_impl.hpp"

namespace cariesim {
namespace {

using test::probe_at;

constexpr double kTipRadius = 0.05;  // mm

// A rigid enamel slab whose top is z = 0.
Model rigid_slab() {
  test::SlabSpec spec;
  return test::model({test::object("slab", test::slab(spec, [](const Vec3&) { return 0; }), ObjectKind::Rigid)},
                     {test::enamel()});
}

// A compliant slab (stiffness k) whose top is z = 0.
Model soft_slab(double k, double mu_s = 0.0, double mu_d = 0.0) {
  test::SlabSpec spec;
  return test::model({test::object("soft", test::slab(spec, [](const Vec3&) { return 0; }), ObjectKind::Soft)},
                     {test::soft(k, mu_s, mu_d)});
}

StepOutput run(const Model& m, State& s, const Pose& haptic, int steps = 1) {
  StepOutput out;
  for (int i = 0; i < steps; ++i) out = step(m, s, HapticInput{haptic, 0.001});
  return out;
}

TEST(Step, FreeSpaceFollowsTheHand) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(0, 0, 5)));
  const StepOutput out = run(m, s, probe_at(Vec3(1, 2, 4)));
  EXPECT_EQ(out.state, InteractionState::Free);
  EXPECT_NEAR((out.graphic.p - Vec3(1, 2, 4)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(out.force.norm(), 0.0, 1e-12);
  EXPECT_NEAR(out.torque.norm(), 0.0, 1e-12);
}

// A sphere-tipped tool pressed into a rigid flat block: force = coupling stiffness x depth along the
// normal, zero torque for a centred push (issue 3 closed-form test).
TEST(Step, RigidPressGivesCouplingStiffnessTimesDepth) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(0, 0, 1)));
  for (double depth : {0.1, 0.5, 1.2}) {
    // Above a sphere's tangent point the union's surface is exactly z = 0.
    const StepOutput out = run(m, s, probe_at(Vec3(0, 0, kTipRadius - depth)), 40);
    EXPECT_EQ(out.state, InteractionState::Sliding);
    EXPECT_NEAR(out.force.z(), m.defaults.gains.k_trans * depth, 2e-3) << depth;
    EXPECT_NEAR(out.force.head<2>().norm(), 0.0, 2e-3) << depth;
    EXPECT_NEAR(out.torque.norm(), 0.0, 1e-6) << depth;
    EXPECT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance);
  }
}

// The diagnostic the step benchmarks report as `pairs`: the sphere pairs the rows of the last
// sub-step were made of. None before any contact; some, within the stage's capacity, while pressing;
// a step in free space (no sub-step) leaves the count of the last sub-step.
TEST(Step, CollectedPairsAreThoseOfTheLastSubstep) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(0, 0, 5)));
  EXPECT_EQ(run(m, s, probe_at(Vec3(0, 0, 4))).state, InteractionState::Free);
  EXPECT_EQ(s.collected_pairs(), 0);
  const StepOutput pressed = run(m, s, probe_at(Vec3(0, 0, kTipRadius - 0.5)), 40);
  ASSERT_EQ(pressed.state, InteractionState::Sliding);
  ASSERT_GT(pressed.substeps, 0);
  const int pairs = s.collected_pairs();
  EXPECT_GT(pairs, 0);
  EXPECT_LE(pairs, 512);
  EXPECT_EQ(pairs, state_impl(s).pairs.count);
  // Lifted off (the sub-steps that leave the slab collect what they meet), then in free space.
  EXPECT_EQ(run(m, s, probe_at(Vec3(0, 0, 8)), 40).state, InteractionState::Free);
  const int last = s.collected_pairs();
  EXPECT_EQ(last, state_impl(s).pairs.count);
  const StepOutput free = run(m, s, probe_at(Vec3(0, 0, 9)));
  EXPECT_EQ(free.state, InteractionState::Free);
  EXPECT_EQ(free.substeps, 0);
  EXPECT_EQ(s.collected_pairs(), last);
}

// On compliant tissue of stiffness k the force is the series stiffness times the depth.
TEST(Step, CompliantPressGivesSeriesStiffness) {
  const double k = 0.5;
  const Model m = soft_slab(k);
  State s(m, probe_at(Vec3(0, 0, 1)));
  const double depth = 0.6;
  const StepOutput out = run(m, s, probe_at(Vec3(0, 0, kTipRadius - depth)), 40);
  const double series = m.defaults.gains.k_trans * k / (m.defaults.gains.k_trans + k);
  EXPECT_NEAR(out.force.z(), series * depth, 3e-3);
  // The graphic tool sank by the tissue's share of the depth.
  EXPECT_NEAR(kTipRadius - out.graphic.p.z(), series * depth / k, 3e-3);
}

// Frictionless sliding has zero tangential force (up to the sphere union's bumps).
TEST(Step, FrictionlessSlidingHasNoTangentialForce) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(-5, 0, 1)));
  double worst_ratio = 0.0;
  for (int i = 0; i <= 2000; ++i) {
    const double x = -5.0 + 10.0 * i / 2000.0;  // 10 mm in 2 s
    const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(x, 0.1, kTipRadius - 0.5)), 0.001});
    if (i < 50) continue;
    ASSERT_GT(out.force.z(), 0.4);
    worst_ratio = std::max(worst_ratio, std::abs(out.force.x()) / out.force.z());
    ASSERT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance) << i;
  }
  // The slab's spheres (R = 2 mm, 0.25 mm apart) tilt the normal by at most ~s/(2R).
  EXPECT_LT(worst_ratio, 0.07);
}

TEST(Step, NonFinitePoseIsFlaggedAndBounded) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(0, 0, 1)));
  run(m, s, probe_at(Vec3(0, 0, kTipRadius - 0.3)), 20);
  Pose bad = probe_at(Vec3(0, std::nan(""), 0));
  const StepOutput out = step(m, s, HapticInput{bad, 0.001});
  EXPECT_TRUE(out.flags & kFlagNonFiniteInput);
  EXPECT_TRUE(out.force.allFinite());
  EXPECT_TRUE(out.graphic.p.allFinite());
  EXPECT_NEAR(out.force.z(), 0.3, 5e-3);  // the last good pose is held
  Pose inf_q = probe_at(Vec3(0, 0, 0));
  inf_q.q = Quat(INFINITY, 0, 0, 0);
  EXPECT_TRUE(step(m, s, HapticInput{inf_q, 0.001}).flags & kFlagNonFiniteInput);
}

// A 50 mm jump in one step: flagged, force bounded by the device, no penetration.
TEST(Step, JumpIsFlaggedBoundedAndDoesNotPenetrate) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(0, 0, 1)));
  run(m, s, probe_at(Vec3(0, 0, 1)), 2);
  StepOutput out = step(m, s, HapticInput{probe_at(Vec3(0, 0, -49)), 0.001});
  EXPECT_TRUE(out.flags & kFlagJumpLimited);
  for (int i = 0; i < 200; ++i) {
    EXPECT_LE(out.force.norm(), m.defaults.limits.max_force + 1e-9);
    EXPECT_TRUE(out.force.allFinite());
    EXPECT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance);
    out = step(m, s, HapticInput{probe_at(Vec3(0, 0, -49)), 0.001});
  }
  EXPECT_TRUE(out.flags & kFlagForceClamped);
  EXPECT_NEAR(out.force.norm(), m.defaults.limits.max_force, 1e-9);
}

// Issue #14 item 6: a 180-degree turn in one step is flagged like a jump (it was not).
TEST(Step, TurnIsFlaggedLikeAJump) {
  const Model m = rigid_slab();
  State s(m, probe_at(Vec3(0, 0, 1)));
  run(m, s, probe_at(Vec3(0, 0, 1)), 2);
  Pose turned = probe_at(Vec3(0, 0, 1));
  turned.q = Quat(Eigen::AngleAxisd(M_PI, Vec3::UnitX())) * turned.q;
  StepOutput out = step(m, s, HapticInput{turned, 0.001});
  EXPECT_TRUE(out.flags & kFlagJumpLimited);
  EXPECT_TRUE(out.torque.allFinite());
  EXPECT_LE(out.torque.norm(), m.defaults.limits.max_torque + 1e-9);
  out = step(m, s, HapticInput{turned, 0.001});
  EXPECT_FALSE(out.flags & kFlagJumpLimited) << "holding the turned pose is no jump";
}

// The step's input stage is the input guard (device/input_guard.hpp) with the model's limits: its
// verdict is the output's input_faults, its jump the step's flag; an invalid reading (a device with no
// pose) holds the last good pose like a non-finite one; a stale reading is used but reported.
TEST(Step, TheInputGuardJudgesWithTheModelsLimits) {
  Model m = rigid_slab();
  m.settings.input.max_jump = 5.0;  // mm
  m.settings.input.stale_after = 0.01;  // s
  State s(m, probe_at(Vec3(0, 0, 1)));
  run(m, s, probe_at(Vec3(0, 0, 1)), 2);
  StepOutput out = step(m, s, HapticInput{probe_at(Vec3(3, 0, 1)), 0.001});
  EXPECT_EQ(out.input_faults, 0u) << "3 mm is within the model's 5 mm";
  EXPECT_FALSE(out.flags & kFlagJumpLimited);
  out = step(m, s, HapticInput{probe_at(Vec3(10, 0, 1)), 0.001});
  EXPECT_EQ(out.input_faults, static_cast<uint32_t>(kInputJump)) << "7 mm is beyond it";
  EXPECT_TRUE(out.flags & kFlagJumpLimited);
  out = step(m, s, HapticInput{probe_at(Vec3(30, 0, 1)), 0.001, false, 0.0});
  EXPECT_EQ(out.input_faults, static_cast<uint32_t>(kInputInvalid));
  EXPECT_EQ(out.haptic.p, Vec3(10, 0, 1)) << "an invalid reading holds the last good pose";
  EXPECT_FALSE(out.flags & kFlagNonFiniteInput);
  out = step(m, s, HapticInput{probe_at(Vec3(10.5, 0, 1)), 0.001, true, 0.02});
  EXPECT_EQ(out.input_faults, static_cast<uint32_t>(kInputStale));
  EXPECT_EQ(out.haptic.p, Vec3(10.5, 0, 1)) << "a stale reading is used; safety zeroes its force";
  Pose long_q = probe_at(Vec3(10.5, 0, 1));
  long_q.q.coeffs() *= 2.0;  // not a rotation: not normalised into one
  out = step(m, s, HapticInput{long_q, 0.001});
  EXPECT_EQ(out.input_faults, static_cast<uint32_t>(kInputNonFinite));
  EXPECT_TRUE(out.flags & kFlagNonFiniteInput);
}

// A wedge: the tool squeezed between two rigid walls closing in from both sides, pushed down into
// the gap. Contradictory constraints must give a finite, bounded output and no penetration.
TEST(Step, WedgeStaysFiniteAndOutsideRigidTissue) {
  test::SlabSpec wall;
  wall.radius = 1.0;
  wall.spacing = 0.2;
  wall.x0 = -3, wall.x1 = 3, wall.y0 = -3, wall.y1 = 3;
  auto left = test::slab(wall, [](const Vec3&) { return 0; });
  auto right = left;
  // Rotate the two slabs into walls facing each other, leaving a 0.08 mm slot narrower than the tip.
  for (auto& l : left) l.center = Vec3f(l.center.z() - 0.04f, l.center.y(), l.center.x());
  for (auto& r : right) r.center = Vec3f(0.04f - r.center.z(), r.center.y(), r.center.x());
  const Model m = test::model({test::object("left", left, ObjectKind::Rigid),
                               test::object("right", right, ObjectKind::Rigid)},
                              {test::enamel()});
  State s(m, probe_at(Vec3(0, 0, 6)));
  for (int i = 0; i < 500; ++i) {
    const double z = 6.0 - 0.02 * i;
    const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(0.01 * std::sin(i * 0.3), 0, z)), 0.001});
    ASSERT_TRUE(out.force.allFinite());
    ASSERT_TRUE(out.graphic.p.allFinite());
    ASSERT_LE(out.force.norm(), m.defaults.limits.max_force + 1e-9);
    ASSERT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance) << i;
  }
}

TEST(Step, IsDeterministic) {
  const Model m = soft_slab(0.8, 0.5, 0.3);
  State a(m, probe_at(Vec3(-3, 0, 1))), b(m, probe_at(Vec3(-3, 0, 1)));
  for (int i = 0; i < 1500; ++i) {
    const Pose h = probe_at(Vec3(-3 + 0.004 * i, 0.3 * std::sin(0.01 * i), kTipRadius - 0.4));
    const StepOutput oa = step(m, a, HapticInput{h, 0.001});
    const StepOutput ob = step(m, b, HapticInput{h, 0.001});
    ASSERT_EQ(oa.force, ob.force) << i;
    ASSERT_EQ(oa.graphic.p, ob.graphic.p) << i;
  }
}

// Stick-slip on a frictional compliant surface: the tangential force builds up to mu_s·F_n and drops
// toward mu_d·F_n when the contact slips, again and again (the saw-tooth of paper Figs. 10-11).
TEST(Step, FrictionMakesASawTooth) {
  auto mean_friction = [](double mu_s, double mu_d, int& slips) {
    const Model m = soft_slab(1.0, mu_s, mu_d);
    State s(m, probe_at(Vec3(-5, 0, 1)));
    double sum = 0.0, ratio_max = 0.0;
    int n = 0;
    slips = 0;
    for (int i = 0; i <= 3000; ++i) {
      const double x = -5.0 + 6.0 * i / 3000.0;
      const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(x, 0, kTipRadius - 0.59)), 0.001});
      slips += out.slips;
      if (i < 300) continue;
      sum += std::abs(out.force.x());
      ratio_max = std::max(ratio_max, std::abs(out.force.x()) / out.force.z());
      ++n;
    }
    EXPECT_LE(ratio_max, mu_s * 1.05 + 0.02);  // never beyond the static cone (+ the union's bumps)
    return sum / n;
  };
  int slips_low = 0, slips_high = 0;
  const double low = mean_friction(0.2, 0.1, slips_low);
  const double high = mean_friction(0.8, 0.3, slips_high);
  EXPECT_GT(high, 2.0 * low);
  EXPECT_GE(slips_low, 3);
  EXPECT_GE(slips_high, 3);
}

// Friction only where the material sets it: the same slide on a frictionless soft slab.
TEST(Step, FrictionlessSoftSlabHasNoSlips) {
  const Model m = soft_slab(1.0);
  State s(m, probe_at(Vec3(-5, 0, 1)));
  int slips = 0;
  for (int i = 0; i <= 1000; ++i)
    slips += step(m, s, HapticInput{probe_at(Vec3(-5.0 + 0.002 * i, 0, kTipRadius - 0.59)), 0.001}).slips;
  EXPECT_EQ(slips, 0);
}

// Anisotropic friction: sliding along the material's direction is easier than across it.
TEST(Step, AnisotropicFrictionDependsOnDirection) {
  auto mean_fx = [](const Vec3& dir_of_motion) {
    test::SlabSpec spec;
    Material mat = test::soft(1.0, 0.7, 0.5);
    mat.aniso_dir = Vec3::UnitX();
    mat.mu_s_along = 0.15;
    mat.mu_d_along = 0.1;
    const Model m = test::model({test::object("soft", test::slab(spec, [](const Vec3&) { return 0; }), ObjectKind::Soft)},
                                {mat});
    State s(m, probe_at(-4.0 * dir_of_motion + Vec3(0, 0, 1)));
    double sum = 0.0;
    for (int i = 0; i <= 2000; ++i) {
      const Vec3 p = (-4.0 + 4.0 * i / 2000.0) * dir_of_motion + Vec3(0, 0, kTipRadius - 0.5);
      const StepOutput out = step(m, s, HapticInput{probe_at(p), 0.001});
      if (i > 300) sum += std::abs(out.force.dot(dir_of_motion));
    }
    return sum;
  };
  EXPECT_GT(mean_fx(Vec3::UnitY()), 2.0 * mean_fx(Vec3::UnitX()));
}

}  // namespace
}  // namespace cariesim
