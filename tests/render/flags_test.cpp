// The step raises each of its flags in the situation it names, with a finite, bounded output and the
// tool outside rigid tissue (docs/design.md §4 "Degenerate input ... yields ... a flag"). Small hand-made
// models: slabs of spheres (render_support.hpp) for floors, walls and slots. The input flags
// (non-finite, jump) and the force clamp are in step_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "render/pairs.hpp"
#include "render/render_support.hpp"
#include "render/state_impl.hpp"

namespace cariesim {
namespace {

using test::probe_at;

constexpr double kTip = 0.05;  // mm

// Slab leaves (top z = 0) over [x0, x1] x [y0, y1].
std::vector<LeafSphere> floor_leaves(double x0, double x1, double y0, double y1, double radius = 2.0) {
  test::SlabSpec spec;
  spec.x0 = x0, spec.x1 = x1, spec.y0 = y0, spec.y1 = y1, spec.radius = radius;
  return test::slab(spec, [](const Vec3&) { return 0; });
}

// A rough rigid slab of small spheres (0.3 mm) long enough for the whole probe lying on it: each shank
// sphere meets several distinct normals.
Model rough_floor() {
  return test::model({test::object("rough", floor_leaves(-2, 42, -2, 2, 0.3), ObjectKind::Rigid)},
                     {test::enamel()});
}

// Slab leaves turned into a wall: the plane x = at, facing -x (sign +1) or +x (sign -1), its
// tangent points spanning z in [z0, z0 + (x1 - x0)].
std::vector<LeafSphere> wall_leaves(double at, double sign, double z0, double x0, double x1,
                                    double radius = 2.0) {
  std::vector<LeafSphere> leaves = floor_leaves(x0, x1, -2.0, 2.0, radius);
  for (LeafSphere& l : leaves) {
    const float z = static_cast<float>(z0 - x0) + l.center.x();
    l.center = Vec3f(static_cast<float>(at + sign * radius), l.center.y(), z);
    l.tangents.normal[0] = Vec3f(static_cast<float>(-sign), 0.0f, 0.0f);
  }
  return leaves;
}

// Everything a flagged step must still honour.
void expect_sane(const Model& m, const StepOutput& out) {
  EXPECT_TRUE(out.force.allFinite() && out.torque.allFinite() && out.graphic.p.allFinite());
  EXPECT_LE(out.force.norm(), m.defaults.limits.max_force + 1e-9);
  EXPECT_LE(out.torque.norm(), m.defaults.limits.max_torque + 1e-9);
}

// The probe lying along +x, its shank `lift` mm above the slab top z = 0.
Pose lying(double x, double lift) {
  return Pose{Vec3(x, 0.0, 1.0 + lift), Quat(Eigen::AngleAxisd(M_PI / 2.0, Vec3::UnitY()))};
}

// Params whose rotational coupling keeps a lying probe flat: the hand, which pulls at the tip, then
// presses the whole shank down instead of tilting it about its first contact.
Params flat(const Model& m) {
  Params p = m.defaults;
  p.gains.k_rot = 1e6;  // N·mm/rad
  return p;
}

// More sphere pairs than the contact capacity.
TEST(StepFlags, ContactOverflow) {
  Model m =
      test::model({test::object("slab", floor_leaves(-2, 2, -2, 2), ObjectKind::Rigid)}, {test::enamel()});
  m.capacities.contacts = 4;
  State s(m, probe_at(Vec3(0, 0, 1)));
  StepOutput out;
  for (int i = 0; i < 30; ++i) out = step(m, s, HapticInput{probe_at(Vec3(0, 0, kTip - 0.3)), 0.001});
  EXPECT_TRUE(out.flags & kFlagContactOverflow);
  EXPECT_TRUE(state_impl(s).pairs.overflow);
  EXPECT_GT(out.contacts, 0);
  EXPECT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance);
  expect_sane(m, out);
  // With room for every pair the same press is not flagged.
  const Model roomy =
      test::model({test::object("slab", floor_leaves(-2, 2, -2, 2), ObjectKind::Rigid)}, {test::enamel()});
  State r(roomy, probe_at(Vec3(0, 0, 1)));
  for (int i = 0; i < 30; ++i) out = step(roomy, r, HapticInput{probe_at(Vec3(0, 0, kTip - 0.3)), 0.001});
  EXPECT_FALSE(out.flags & kFlagContactOverflow);
}

// A step's collision work is bounded (StepSettings::work_budget, issue #14 item 10): the whole probe
// pressed into a rough rigid slab of small spheres with a budget far below what its queries need.
// Every step stays within the budget, says so, and keeps the tool out of
// the slab; with the default budget the same press is not flagged.
TEST(StepFlags, WorkBudget) {
  Model m = rough_floor();
  m.settings.work_budget = 400;
  const Params p = flat(m);
  State s(m, lying(0.0, 0.05));
  bool flagged = false;
  StepOutput out;
  for (int i = 0; i < 40; ++i) {
    out = step(m, p, s, HapticInput{lying(0.0, -0.5), 0.001});
    EXPECT_LE(out.work, m.settings.work_budget) << i;
    flagged = flagged || (out.flags & kFlagWorkBudget);
    expect_sane(m, out);
    ASSERT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance) << i;
  }
  EXPECT_TRUE(flagged);

  const Model roomy = rough_floor();
  State r(roomy, lying(0.0, 0.05));
  int64_t most = 0;
  for (int i = 0; i < 40; ++i) {
    out = step(roomy, p, r, HapticInput{lying(0.0, -0.5), 0.001});
    EXPECT_FALSE(out.flags & kFlagWorkBudget) << i;
    most = std::max(most, out.work);
  }
  EXPECT_GT(most, m.settings.work_budget);  // the small budget did cut work short
}

// The whole probe lying on a rough rigid slab (small spheres: each shank sphere meets several distinct
// normals, a row each): more rows than the QP holds.
TEST(StepFlags, QpRowsFull) {
  const Model m = rough_floor();
  const Params p = flat(m);
  State s(m, lying(0.0, 0.05));
  bool flagged = false;
  StepOutput out;
  for (int i = 0; i < 20; ++i) {
    out = step(m, p, s, HapticInput{lying(0.0, -0.5), 0.001});
    if (out.flags & kFlagQpRowsFull) {
      flagged = true;
      EXPECT_EQ(state_impl(s).rows.problem.row_count, kQpMaxRows);
      EXPECT_TRUE(state_impl(s).rows.full);
    }
    expect_sane(m, out);
    ASSERT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance) << i;
  }
  EXPECT_TRUE(flagged);
}

// The whole probe pressed into two coincident soft slabs: one compliant row per region, and more
// regions want force than the QP's active set holds (kQpMaxActive).
TEST(StepFlags, QpActiveSetFull) {
  const auto slab = floor_leaves(-2, 42, -2, 2);
  const Model m =
      test::model({test::object("a", slab, ObjectKind::Soft), test::object("b", slab, ObjectKind::Soft)},
                  {test::soft(1.0)});
  const Params p = flat(m);
  State s(m, lying(0.0, 0.05));
  bool flagged = false;
  StepOutput out;
  for (int i = 0; i < 20; ++i) {
    out = step(m, p, s, HapticInput{lying(0.0, -0.5), 0.001});
    if (out.flags & kFlagQpActiveSetFull) {
      flagged = true;
      // The last solve is the full one unless the work budget cut the step's sub-steps short (the
      // whole probe in two soft slabs is close to it, StepSettings::work_budget).
      if (!(out.flags & kFlagWorkBudget)) {
        EXPECT_EQ(state_impl(s).solution.qp.active, kQpMaxActive) << i;
      }
    }
    expect_sane(m, out);
  }
  EXPECT_TRUE(flagged);
  EXPECT_GT(state_impl(s).regions.count, kQpMaxActive);
}

// A solver allowed a single dual step cannot settle the probe landing flat on a rigid slab (the
// first contact rows each let the tool pivot onto the next): the step says so, and still answers with
// the solver's last, finite iterate.
TEST(StepFlags, QpIterationLimit) {
  const Model m =
      test::model({test::object("slab", floor_leaves(-2, 42, -2, 2), ObjectKind::Rigid)}, {test::enamel()});
  const Params p = flat(m);
  State s(m, lying(0.0, 0.05));
  state_impl(s).solver = QpSolver(1);
  bool flagged = false;
  StepOutput out;
  for (int i = 0; i < 20; ++i) {
    out = step(m, p, s, HapticInput{lying(0.0, -0.5), 0.001});
    flagged = flagged || (out.flags & kFlagQpIterationLimit);
    expect_sane(m, out);
  }
  EXPECT_TRUE(flagged);
  // With the solver's usual budget the same landing is solved.
  State normal(m, lying(0.0, 0.05));
  for (int i = 0; i < 20; ++i) {
    out = step(m, p, normal, HapticInput{lying(0.0, -0.5), 0.001});
    EXPECT_FALSE(out.flags & kFlagQpIterationLimit) << i;
  }
}

// The tip wedged in a slot narrower than itself (the model's home pose: a State starts there when the
// asked pose overlaps): the two walls' rows contradict each other, so the solve is infeasible and the
// tool holds still; the overlap it started in cannot be backtracked away either.
TEST(StepFlags, InfeasibleWedge) {
  Model m = test::model({test::object("left", wall_leaves(-0.04, -1.0, -1.0, -0.5, 0.5), ObjectKind::Rigid),
                         test::object("right", wall_leaves(0.04, 1.0, -1.0, -0.5, 0.5), ObjectKind::Rigid)},
                        {test::enamel()});
  m.tool_home = probe_at(Vec3(0, 0, -0.5));
  State s(m, m.tool_home);
  ASSERT_LT(test::rigid_clearance(m, s.graphic()), -m.settings.rigid_tolerance) << "wedged";
  const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(0.2, 0, -0.6)), 0.001});
  EXPECT_TRUE(out.flags & kFlagInfeasible);
  EXPECT_TRUE(out.flags & kFlagBacktracked);
  EXPECT_EQ(out.graphic.p, m.tool_home.p) << "infeasible: the tool holds still";
  expect_sane(m, out);
}

// A floor, a wall, a contact capacity of one pair and no re-check pass to spare: the rows miss the
// wall, the solution enters it, and the step is backtracked to the largest clear fraction.
TEST(StepFlags, Backtracked) {
  Model m = test::model({test::object("floor", floor_leaves(-3, 3, -3, 3), ObjectKind::Rigid),
                         test::object("wall", wall_leaves(0.4, 1.0, 0.0, -0.5, 0.5), ObjectKind::Rigid)},
                        {test::enamel()});
  m.capacities.contacts = 1;
  m.settings.max_rechecks = -1;
  State s(m, probe_at(Vec3(0, 0, kTip + 0.001)));
  bool flagged = false;
  for (int i = 0; i < 20; ++i) {
    const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(1.0, 0, kTip)), 0.001});
    flagged = flagged || (out.flags & kFlagBacktracked);
    ASSERT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance) << i;
    expect_sane(m, out);
  }
  EXPECT_TRUE(flagged);
}

// A hand far inside a rigid slab: the sub-step budget runs out before the tool gets there.
TEST(StepFlags, Lagging) {
  const Model m =
      test::model({test::object("slab", floor_leaves(-3, 3, -3, 3), ObjectKind::Rigid)}, {test::enamel()});
  State s(m, probe_at(Vec3(0, 0, kTip + 0.5)));
  const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(2.0, 0, -3.0)), 0.001});
  EXPECT_TRUE(out.flags & kFlagLagging);
  EXPECT_EQ(out.substeps, m.settings.max_substeps);
  expect_sane(m, out);
  // A hand within reach is followed within the cycle: no lag.
  State near(m, probe_at(Vec3(0, 0, kTip + 0.5)));
  EXPECT_FALSE(step(m, near, HapticInput{probe_at(Vec3(0, 0, kTip + 0.495)), 0.001}).flags & kFlagLagging);
}

// The torque clamp against Params::limits: the probe lying just above a rigid slab, the hand turning
// its far end down into the slab; the slab stops the turn, and the coupling's torque exceeds the
// lowered limit.
TEST(StepFlags, TorqueClamped) {
  const Model m =
      test::model({test::object("slab", floor_leaves(-2, 42, -2, 2), ObjectKind::Rigid)}, {test::enamel()});
  Params p = m.defaults;
  p.limits.max_torque = 1.0;  // N·mm
  const Pose start = lying(0.0, 0.05);
  const Pose turned{start.p, Quat(Eigen::AngleAxisd(0.2, Vec3::UnitY())) * start.q};
  State s(m, start);
  StepOutput out;
  for (int i = 0; i < 40; ++i) out = step(m, p, s, HapticInput{turned, 0.001});
  EXPECT_TRUE(out.flags & kFlagTorqueClamped);
  EXPECT_NEAR(out.torque.norm(), 1.0, 1e-9);
  expect_sane(m, out);
  const StepOutput unclamped = step(m, s, HapticInput{turned, 0.001});
  EXPECT_FALSE(unclamped.flags & kFlagTorqueClamped) << "within the model's limits";
  EXPECT_GT(unclamped.torque.norm(), 1.0);
}

// Params made for another model: nothing is done, and the step says why.
TEST(StepFlags, WrongState) {
  const Model m =
      test::model({test::object("slab", floor_leaves(-3, 3, -3, 3), ObjectKind::Rigid)}, {test::enamel()});
  Params p = m.defaults;
  p.materials.push_back(test::enamel());
  State s(m, probe_at(Vec3(0, 0, 1)));
#ifdef NDEBUG
  const StepOutput out = step(m, p, s, HapticInput{probe_at(Vec3(0, 0, 2)), 0.001});
  EXPECT_EQ(out.flags, static_cast<uint32_t>(kFlagWrongState));
  EXPECT_EQ(s.graphic().p, Vec3(0, 0, 1));
#else
  EXPECT_DEATH(step(m, p, s, HapticInput{probe_at(Vec3(0, 0, 2)), 0.001}), "params made for another model");
#endif
}

}  // namespace
}  // namespace cariesim
