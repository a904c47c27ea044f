// The sub-step (src/render/substep.cpp), tested directly: bounded by its trust region, stopped by a
// rigid surface, the re-check that brings in pairs the rows missed (measured at the rows'
// configuration), and the backtrack that keeps the tool out of rigid tissue; and the sliding state's
// sub-step budget.
#include "render/substep.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "render/contact_rows.hpp"
#include "render/pairs.hpp"
#include "render/render_support.hpp"
#include "render/state_impl.hpp"

namespace cariesim {
namespace {

using namespace detail;
using test::probe_at;

constexpr double kTip = 0.05;  // mm

// A rigid slab (top z = 0).
Model rigid_slab() {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -3.0;
  spec.x1 = spec.y1 = 3.0;
  return test::model(
      {test::object("slab", test::slab(spec, [](const Vec3&) { return 0; }), ObjectKind::Rigid)},
      {test::enamel()});
}

// A low rigid wall: the plane x = 0.4 facing -x, its tangent points over z in [0, 1] (the probe
// upright at x = 0 clears it: its spheres are thinner than 0.4 mm up to where the wall recedes).
std::vector<LeafSphere> low_wall() {
  test::SlabSpec spec;
  spec.x0 = -0.5;
  spec.x1 = 0.5;
  spec.y0 = -2.0;
  spec.y1 = 2.0;
  std::vector<LeafSphere> wall = test::slab(spec, [](const Vec3&) { return 0; });
  for (LeafSphere& l : wall) {
    l.center = Vec3f(0.4f + 2.0f, l.center.y(), l.center.x() + 0.5f);
    l.tangents.normal[0] = -Vec3f::UnitX();
  }
  return wall;
}

// A request pulling toward `target` with the default coupling, bounded by `trans` mm and `rot` rad.
SubstepRequest request(const Model& m, const Vec6& target, double trans, double rot) {
  SubstepRequest req;
  req.target = target;
  req.G.setZero();
  req.G.diagonal() << m.defaults.gains.k_trans, m.defaults.gains.k_trans, m.defaults.gains.k_trans,
      m.defaults.gains.k_rot, m.defaults.gains.k_rot, m.defaults.gains.k_rot;
  req.trans_bound = trans;
  req.rot_bound = rot;
  return req;
}

// In free space the sub-step moves toward the target by at most its bounds, exactly onto them when
// the target lies beyond (then it has not reached it), all the way when within.
TEST(Substep, BoundedByItsTrustRegion) {
  const Model m = rigid_slab();
  State state(m, probe_at(Vec3(0, 0, 10)));
  StateImpl& s = state_impl(state);
  const Pose g0 = probe_at(Vec3(0, 0, 10));
  Vec6 far;
  far << 3.0, -4.0, 0.0, 0.0, 0.0, 0.0;  // 5 mm
  StepTrace trace;
  bool reached = true;
  const Pose g1 = solve_substep(m, m.defaults, s, g0, request(m, far, 0.1, 0.01), trace, reached);
  EXPECT_FALSE(reached);
  EXPECT_NEAR((g1.p - g0.p).norm(), 0.1, 1e-12);
  EXPECT_NEAR(((g1.p - g0.p) - 0.1 * far.head<3>().normalized()).norm(), 0.0, 1e-12);
  // A rotation beyond the rotation bound is shortened the same way.
  Vec6 turn = Vec6::Zero();
  turn[4] = 0.5;  // rad about y
  const Pose g2 = solve_substep(m, m.defaults, s, g0, request(m, turn, 0.1, 0.01), trace, reached);
  EXPECT_FALSE(reached);
  EXPECT_NEAR(rotation_vector(g2.q * g0.q.conjugate()).norm(), 0.01, 1e-12);
  // Within the bounds: all the way.
  Vec6 near = Vec6::Zero();
  near.x() = 0.05;
  const Pose g3 = solve_substep(m, m.defaults, s, g0, request(m, near, 0.1, 0.01), trace, reached);
  EXPECT_TRUE(reached);
  EXPECT_NEAR((g3.p - g0.p - Vec3(0.05, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_EQ(trace.flags, 0u);
}

// Pulled down into a rigid slab, the tool stops on its surface: the sub-step has reached its
// (constrained) goal within the bound, with the tip touching and not inside.
TEST(Substep, StopsOnARigidSurface) {
  const Model m = rigid_slab();
  State state(m, probe_at(Vec3(0, 0, 10)));
  StateImpl& s = state_impl(state);
  const Pose g0 = probe_at(Vec3(0.1, 0.05, kTip + 0.05));
  Vec6 down = Vec6::Zero();
  down.z() = -1.0;
  StepTrace trace;
  bool reached = false;
  const Pose g1 = solve_substep(m, m.defaults, s, g0, request(m, down, 0.2, 0.01), trace, reached);
  EXPECT_TRUE(reached);
  const double gap = test::rigid_clearance(m, g1);
  EXPECT_GE(gap, -m.settings.rigid_tolerance);
  EXPECT_LT(gap, 1e-6);
  EXPECT_GT(s.solution.region_force[0], 0.9) << "the slab carries the pull (1 N/mm x 0.95 mm)";
  EXPECT_EQ(trace.contacts, s.rows.contacts);
  EXPECT_EQ(trace.flags, 0u);
}

// A floor and a wall, and a contact capacity of one pair: the rows hold only the floor's nearest
// pair, so the tool slides into the wall; the re-check at the solution brings the wall's pair in
// (forced, measured at the rows' configuration like every other) and the second solve stops at
// the wall.
TEST(Substep, ReCheckBringsInThePairsTheRowsMissed) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -3.0;
  spec.x1 = spec.y1 = 3.0;
  const auto floor = test::slab(spec, [](const Vec3&) { return 0; });
  const auto wall = low_wall();
  Model m = test::model(
      {test::object("floor", floor, ObjectKind::Rigid), test::object("wall", wall, ObjectKind::Rigid)},
      {test::enamel()});
  m.capacities.contacts = 1;
  State state(m, probe_at(Vec3(0, 0, 10)));
  StateImpl& s = state_impl(state);
  const Pose g0 = probe_at(Vec3(0.0, 0.0, kTip + 0.001));
  Vec6 target = Vec6::Zero();
  target.x() = 1.0;
  target.z() = -0.2;
  StepTrace trace;
  bool reached = false;
  const Pose g1 = solve_substep(m, m.defaults, s, g0, request(m, target, 1.0, 0.02), trace, reached);
  EXPECT_TRUE(trace.flags & kFlagContactOverflow);
  EXPECT_GE(test::rigid_clearance(m, g1), -m.settings.rigid_tolerance);
  int forced_on_wall = 0;
  for (int i = 0; i < s.pairs.count; ++i) {
    if (!s.pairs.refs[i].forced) continue;
    forced_on_wall += s.pairs.refs[i].object == 1;
    const PairGeometry at_rows = measure_pair(m, s.constants, s.pairs.at, s.pairs.refs[i]);
    EXPECT_EQ(s.pairs.geometry[i].gap, at_rows.gap);
    EXPECT_EQ(s.pairs.geometry[i].normal, at_rows.normal);
  }
  EXPECT_GE(forced_on_wall, 1);
  EXPECT_EQ(s.pairs.at.p, g0.p);
  EXPECT_LT(g1.p.x(), 0.4) << "stopped at the wall";
}

// Without a re-check pass to spare, the overlap the rows missed is backtracked: the step is shortened
// until the tool is clear, and flagged.
// The re-check and the backtrack read the rigid overlaps at a solution from the pairs collected at
// the sub-step's start instead of the trees (issue #11): for any motion within the sub-step's bounds
// they give what a full tree search gives, also where a tool leaf's quota of pairs was full.
TEST(Substep, ReCheckFromTheCollectedPairsMatchesTheTrees) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -3.0;
  spec.x1 = spec.y1 = 3.0;
  spec.radius = 0.3;
  spec.spacing = 0.1;  // dense: the tip region's leaves and the shank's reach their quotas
  const Model m = test::model(
      {test::object("rough", test::slab(spec, [](const Vec3&) { return 0; }), ObjectKind::Rigid)},
      {test::enamel()});
  StateImpl s(m);
  PlacedTool placed(m.tool.tree);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int capped = 0, overlapping = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const double trans = 0.1, rot = 0.02;  // mm, rad: the trust region
    const Quat tilt(Eigen::AngleAxisd(0.6 * u(rng), Vec3(u(rng), u(rng), 0.0).normalized()));
    const Pose g0{Vec3(0.5 * u(rng), 0.5 * u(rng), kTip + 0.05 * u(rng)), tilt};
    test::collect(m, s, g0, trans, rot);
    ASSERT_EQ(s.collision.complete, s.constants.all_mask) << trial;
    capped += !s.collision.contacts.capped().empty();
    for (int k = 0; k < 10; ++k) {
      Vec6 d;
      d.head<3>() = Vec3(u(rng), u(rng), u(rng)).normalized() * trans * std::abs(u(rng));
      d.tail<3>() = Vec3(u(rng), u(rng), u(rng)).normalized() * rot * std::abs(u(rng));
      const Pose g1 = apply_displacement(g0, d);
      placed.place(g1, 0.0);
      const ClosestPair tree = closest(placed, m.objects, s.constants.rigid_mask, 0.0);
      const double want = std::isfinite(tree.gap) ? std::min(tree.gap, 0.0) : 0.0;
      EXPECT_NEAR(rigid_clearance(m, s.constants, s.collision, g1, s.constants.all_mask), want, 1e-9)
          << trial << " " << k;
      overlapping += want < 0.0;
    }
  }
  EXPECT_GT(capped, 0);         // the capped tool leaves were searched in the trees
  EXPECT_GT(overlapping, 100);  // and the motions did overlap
}

// A listed pair may have no row (its normal is close to a deeper pair's of the same tool leaf and
// object, build_contact_rows); when the solution pushes it in beyond the tolerance, the re-check gives
// it a row (forced) so that the sub-step is solved again, instead of backtracking (issue #11: on the
// real-arch raster 72 % of the sub-steps backtracked for pairs already listed).
TEST(Substep, ReCheckGivesAListedPairWithoutARowItsRow) {
  const Model m = rigid_slab();
  StateImpl s(m);
  const Pose g0 = probe_at(Vec3(0.02, 0.01, kTip + 0.002));
  test::collect(m, s, g0, 0.1, 0.01);
  ASSERT_GT(s.pairs.count, 3);
  for (int i = 0; i < s.pairs.count; ++i) ASSERT_FALSE(s.pairs.refs[i].forced);
  const int listed = s.pairs.count;
  // 0.03 mm down: the tip overlaps the slab's leaves under it by more than the tolerance.
  const Pose g1 = probe_at(Vec3(0.02, 0.01, kTip - 0.028));
  const Recheck check = recheck_rigid(m, s.constants, s.collision, g1, s.constants.all_mask, s.pairs);
  ASSERT_LT(check.worst, -m.settings.rigid_tolerance);
  // Listed pairs that overlap get their row; pairs beyond the list (a capped tool leaf's) come in forced.
  int forced = 0, upgraded = 0;
  const Mat3 rot = g1.q.toRotationMatrix();
  for (int i = 0; i < s.pairs.count; ++i) {
    const PairRef& p = s.pairs.refs[i];
    const SphereNode& node = m.objects[p.object].tree.nodes[p.object_node];
    const double gap = (g1.p + rot * s.constants.leaf_local[p.tool_leaf] - node.center.cast<double>()).norm() -
                       s.constants.leaf_radius[p.tool_leaf] - node.radius;
    EXPECT_EQ(p.forced, gap < -m.settings.rigid_tolerance) << i;
    forced += p.forced;
    upgraded += p.forced && i < listed;
    for (int j = 0; j < i; ++j) {
      const PairRef& q = s.pairs.refs[j];
      EXPECT_FALSE(q.object_node == p.object_node && q.tool_leaf == p.tool_leaf && q.object == p.object) << i;
    }
  }
  EXPECT_GT(upgraded, 0);
  EXPECT_EQ(check.added, forced);
}

// The free-space check's shortcut: a pair of the last collection within reach at the tool's pose
// shows the tool is not in free space (the sliding state then skips the tree search); a pose far
// from every listed pair does not.
TEST(Substep, ListedPairsShowTheToolIsNear) {
  const Model m = rigid_slab();
  StateImpl s(m);
  const Pose g0 = probe_at(Vec3(0.0, 0.0, kTip + 0.01));
  test::collect(m, s, g0, 0.05, 0.01);
  ASSERT_GT(s.collision.contacts.size(), 0u);
  EXPECT_TRUE(listed_within(m, s.constants, s.collision, g0, 0.02));
  const Pose above = probe_at(Vec3(0.0, 0.0, kTip + 5.0));
  EXPECT_FALSE(listed_within(m, s.constants, s.collision, above, 0.1));
  EXPECT_TRUE(listed_within(m, s.constants, s.collision, above, 5.1));
  s.collision.contacts.clear();
  EXPECT_FALSE(listed_within(m, s.constants, s.collision, g0, 1.0)) << "nothing listed";
}

TEST(Substep, BacktracksWhatTheReCheckCannotFix) {
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -3.0;
  spec.x1 = spec.y1 = 3.0;
  const auto floor = test::slab(spec, [](const Vec3&) { return 0; });
  const auto wall = low_wall();
  Model m = test::model(
      {test::object("floor", floor, ObjectKind::Rigid), test::object("wall", wall, ObjectKind::Rigid)},
      {test::enamel()});
  m.capacities.contacts = 1;
  m.settings.max_rechecks = -1;  // one pass: no second solve with the re-check's pairs
  State state(m, probe_at(Vec3(0, 0, 10)));
  StateImpl& s = state_impl(state);
  const Pose g0 = probe_at(Vec3(0.0, 0.0, kTip + 0.001));
  Vec6 target = Vec6::Zero();
  target.x() = 1.0;
  StepTrace trace;
  bool reached = false;
  const Pose g1 = solve_substep(m, m.defaults, s, g0, request(m, target, 1.0, 0.02), trace, reached);
  EXPECT_TRUE(trace.flags & kFlagBacktracked);
  const double gap = test::rigid_clearance(m, g1);
  EXPECT_GE(gap, -m.settings.rigid_tolerance);
  EXPECT_GT(g1.p.x(), 0.1) << "shortened, not dropped: the tool went as far as it could";
}

// The sliding state's budget: a hand 5 mm into a rigid slab is followed by at most max_substeps
// sub-steps of doubling bounds (from 0.01 mm up to the trust step) in one cycle; the tool lags, says
// so, uses most of its budget, and never enters the slab.
TEST(Substep, SlidingBudgetLagsBehindAFarHand) {
  const Model m = rigid_slab();
  const Vec3 start(0, 0, kTip + 0.3);
  State s(m, probe_at(start));
  const StepOutput out = step(m, s, HapticInput{probe_at(Vec3(2.0, 0, -5.0)), 0.001});
  EXPECT_TRUE(out.flags & kFlagLagging);
  EXPECT_EQ(out.substeps, m.settings.max_substeps);
  double budget = 0.0, bound = 0.01;
  for (int k = 0; k < m.settings.max_substeps; ++k, bound = std::min(2.0 * bound, m.settings.trust_step))
    budget += bound;
  const double moved = (out.graphic.p - start).norm();
  EXPECT_LE(moved, budget + 1e-12);
  EXPECT_GT(moved, 0.5 * budget);
  EXPECT_GE(test::rigid_clearance(m, out.graphic), -m.settings.rigid_tolerance);
  // A hand within reach is followed within the cycle.
  const StepOutput near = step(m, s, HapticInput{probe_at(out.graphic.p + Vec3(0, 0, -0.02)), 0.001});
  EXPECT_FALSE(near.flags & kFlagLagging);
  EXPECT_LT(near.substeps, m.settings.max_substeps);
}

// The work budget and the sub-steps (issue #14 item 10): a further sub-step starts only while what is
// left of the budget covers the costliest sub-step so far, so a step never runs a sub-step it cannot
// finish. With a budget of about half the six sub-steps' work the step stops early, before the
// budget is spent, says so, and stays out of the slab; with the default it runs all six unflagged.
TEST(Substep, AFurtherSubStepStartsOnlyWhileTheBudgetCoversIt) {
  Model m = rigid_slab();
  const Vec3 start(0, 0, kTip + 0.3);
  const HapticInput far{probe_at(Vec3(2.0, 0, -5.0)), 0.001};
  State roomy(m, probe_at(start));
  const StepOutput all = step(m, roomy, far);
  ASSERT_EQ(all.substeps, m.settings.max_substeps);
  EXPECT_FALSE(all.flags & kFlagWorkBudget);
  m.settings.work_budget = all.work / 2;
  State tight(m, probe_at(start));
  const StepOutput some = step(m, tight, far);
  EXPECT_TRUE(some.flags & kFlagWorkBudget);
  EXPECT_TRUE(some.flags & kFlagLagging);
  EXPECT_GE(some.substeps, 1);
  EXPECT_LT(some.substeps, m.settings.max_substeps);
  EXPECT_LE(some.work, m.settings.work_budget);
  // Stopped by the gate, not by a query running out: budget left over, and the sub-steps that ran
  // are those of an unbounded step, so the tool is where one allowed as many sub-steps ends (clear).
  EXPECT_LT(some.work, m.settings.work_budget);
  Model fewer = rigid_slab();
  fewer.settings.max_substeps = some.substeps;
  State same_start(fewer, probe_at(start));
  const StepOutput same = step(fewer, same_start, far);
  EXPECT_NEAR((same.graphic.p - some.graphic.p).norm(), 0.0, 1e-12);
  EXPECT_GE(test::rigid_clearance(m, some.graphic), -m.settings.rigid_tolerance);
  EXPECT_GT((some.graphic.p - start).norm(), 0.01);  // beyond the first sub-step's bound
}

// Issue #11: the work budget is per 1 ms of simulated time (kWorkBudgetCycle). At 4 kHz a further
// sub-step starts only within a quarter of it, so a lagging step stops earlier (flagged) than the
// same step at 1 kHz; the first sub-step keeps the whole budget, so the tool still moves.
TEST(Substep, AShorterCycleGivesFurtherSubStepsItsShareOfTheBudget) {
  Model m = rigid_slab();
  const Vec3 start(0, 0, kTip + 0.3);
  const Pose far = probe_at(Vec3(2.0, 0, -5.0));
  State at_1khz(m, probe_at(start));
  const StepOutput slow = step(m, at_1khz, HapticInput{far, 0.001});
  ASSERT_EQ(slow.substeps, m.settings.max_substeps);
  ASSERT_FALSE(slow.flags & kFlagWorkBudget);
  // A budget the six sub-steps need more than a quarter of, but less than all of.
  m.settings.work_budget = slow.work * 3 / 2;
  State at_4khz(m, probe_at(start));
  const StepOutput fast = step(m, at_4khz, HapticInput{far, 0.00025});
  EXPECT_TRUE(fast.flags & kFlagWorkBudget);
  EXPECT_TRUE(fast.flags & kFlagLagging);
  EXPECT_GE(fast.substeps, 1);
  EXPECT_LT(fast.substeps, m.settings.max_substeps);
  EXPECT_LE(fast.work, m.settings.work_budget / 4);
  EXPECT_GT((fast.graphic.p - start).norm(), 0.0);
  EXPECT_GE(test::rigid_clearance(m, fast.graphic), -m.settings.rigid_tolerance);
  // The same budget at 1 kHz runs all six sub-steps unflagged.
  State again(m, probe_at(start));
  const StepOutput same = step(m, again, HapticInput{far, 0.001});
  EXPECT_EQ(same.substeps, m.settings.max_substeps);
  EXPECT_FALSE(same.flags & kFlagWorkBudget);
}

// Issue #11: a cycle that ends lagging passes on what its last sub-step asked for, and the next cycle's
// first bound starts there instead of at twice its (bounded) motion. With one sub-step a cycle, a
// tool at rest with the hand far away moves 0.01 mm in the first cycle and a whole trust step in the
// second (0.025 mm before).
TEST(Substep, ACycleThatEndedLaggingStartsTheNextWhereItLeftOff) {
  Model m = rigid_slab();
  m.settings.max_substeps = 1;
  const Vec3 start(0, 0, kTip + 0.3);
  const HapticInput far{probe_at(Vec3(2.0, 0, -5.0)), 0.001};
  State s(m, probe_at(start));
  const StepOutput first = step(m, s, far);
  ASSERT_TRUE(first.flags & kFlagLagging);
  const double moved_first = (first.graphic.p - start).norm();
  EXPECT_LE(moved_first, 0.01 + 1e-12);
  const StepOutput second = step(m, s, far);
  EXPECT_TRUE(second.flags & kFlagLagging);
  const double moved_second = (second.graphic.p - first.graphic.p).norm();
  EXPECT_GT(moved_second, 2.0 * moved_first + 0.005 + 1e-6) << "the first bound restarted from the motion";
  EXPECT_LE(moved_second, m.settings.trust_step + 1e-12);
  EXPECT_GE(test::rigid_clearance(m, second.graphic), -m.settings.rigid_tolerance);
}

}  // namespace
}  // namespace cariesim
