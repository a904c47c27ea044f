// The penetration state's stages (src/render/tunnel.cpp), tested directly: the tunnel's rows hold
// the tip on its axis and the orientation locked (Fig. 5, eq. 7), its bottom and the tissue's hold
// bound the travel (eqs. 5, 9); the entry criteria (eqs. 3-4); depth growth per eq. 5, rate
// independent; extraction (eqs. 8-9); the displayed spheres; and, through the step, the tip held on
// the axis with the feedback of eqs. 6-7.
#include <gtest/gtest.h>

#include <cmath>

#include "render/render_support.hpp"
#include "render/solve.hpp"
#include "render/state_impl.hpp"
#include "render/tunnel.hpp"

namespace cariesim {
namespace {

using namespace detail;
using test::probe_at;

constexpr double kTip = 0.05;  // mm

// A caries slab (top z = 0, 10 N/mm) with a disk lesion 1.5 mm deep under the origin, the caries
// material k_e 1 N/mm, constant k_c 10 N/mm, F_p* 3 N, F_e* 1 N.
Model lesion_model() {
  Material caries = test::soft(10.0, 0.0, 0.0, Tissue::Caries);
  caries.lesion = 0;
  caries.k_e = 1.0;
  caries.k_c.values.fill(10.0);
  caries.f_p_star = 3.0;
  caries.f_e_star = 1.0;
  caries.k_theta = 100.0;
  test::SlabSpec spec;
  spec.x0 = spec.y0 = -2.0;
  spec.x1 = spec.y1 = 2.0;
  Model m = test::model(
      {test::object("caries", test::slab(spec, [](const Vec3&) { return 0; }), ObjectKind::Soft, 0)},
      {caries});
  LesionModel lesion;
  lesion.name = "lesion1";
  lesion.object = 0;
  lesion.material = 0;
  lesion.shape.kind = LesionShape::Kind::Disk;
  lesion.shape.center = Vec3::Zero();
  lesion.shape.size = 3.0;
  lesion.shape.depth = 1.5;
  lesion.authored_depth = 1.5;
  m.lesions.push_back(lesion);
  return m;
}

// A tunnel straight down (n = -z) from the origin, the tool upright.
Tunnel straight_down(double depth) {
  Tunnel t;
  t.entry = Vec3::Zero();
  t.n = -Vec3::UnitZ();
  t.depth = depth;
  t.max_depth = 1.4;
  t.lesion = 0;
  t.object = 0;
  return t;
}

// Solves the tunnel's rows alone from g0 toward `target` with the tunnel's stiffness.
Pose solve_tunnel(const TunnelLimits& limits, const Pose& g0, const Vec6& target) {
  RowSet rows;
  Mat6 G = Mat6::Identity();
  G.diagonal().tail<3>().setConstant(100.0);
  rows.clear(G, target);
  build_tunnel_rows(limits, g0, rows);
  EXPECT_EQ(rows.problem.row_count, 7);
  EXPECT_FALSE(rows.full);
  RegionSet regions;
  QpSolver solver;
  Solution solution;
  solve_rows(rows, regions, solver, solution);
  EXPECT_EQ(solution.flags, 0u);
  return apply_displacement(g0, solution.d);
}

// The four side spheres and the lock: whatever the hand does sideways or in rotation, the tip comes
// back onto the axis and the orientation to the one frozen at entry; the bottom sphere bounds the
// travel (here the hand pushes far deeper than `upper`).
TEST(TunnelRows, HoldTheTipOnTheAxisAndTheOrientationLocked) {
  const Tunnel t = straight_down(0.5);
  const TunnelLimits limits{&t, 0.5, 0.6};
  // Start slightly off the axis and turned; pull sideways, deeper and turning further.
  const Pose g0{Vec3(0.01, -0.02, -0.5), Quat(Eigen::AngleAxisd(0.01, Vec3(1, 2, 0).normalized()))};
  Vec6 target;
  target << 1.0, 2.0, -3.0, 0.1, -0.2, 0.05;
  const Pose g1 = solve_tunnel(limits, g0, target);
  EXPECT_NEAR(g1.p.head<2>().norm(), 0.0, 1e-12) << "the tip is back on the axis";
  EXPECT_NEAR(rotation_vector(g1.q * t.q_lock.conjugate()).norm(), 0.0, 1e-9) << "the orientation is locked";
  EXPECT_NEAR((g1.p - t.entry).dot(t.n), 0.6, 1e-12) << "the bottom sphere stops the travel at `upper`";
}

// The tissue's hold (eq. 9): pulled back, the tip stays at `lower`.
TEST(TunnelRows, TheTissueHoldsTheTipAtLower) {
  const Tunnel t = straight_down(0.5);
  const TunnelLimits limits{&t, 0.5, 0.5};
  Vec6 target = Vec6::Zero();
  target.z() = 2.0;  // pulled up, out of the lesion
  const Pose g1 = solve_tunnel(limits, probe_at(Vec3(0, 0, -0.5)), target);
  EXPECT_NEAR((g1.p - t.entry).dot(t.n), 0.5, 1e-12);
}

// The rows' kinds and keys: two lateral, three rotation, bottom and hold, in the tunnel key space.
TEST(TunnelRows, KindsAndKeys) {
  const Tunnel t = straight_down(0.2);
  const TunnelLimits limits{&t, 0.1, 0.3};
  RowSet rows;
  rows.clear(Mat6::Identity(), Vec6::Zero());
  build_tunnel_rows(limits, probe_at(Vec3(0, 0, -0.2)), rows);
  ASSERT_EQ(rows.problem.row_count, 7);
  const RowKind kinds[7] = {RowKind::TunnelLateral,  RowKind::TunnelLateral,  RowKind::TunnelRotation,
                            RowKind::TunnelRotation, RowKind::TunnelRotation, RowKind::TunnelBottom,
                            RowKind::TunnelHold};
  const TunnelRow keys[7] = {TunnelRow::Lateral0,  TunnelRow::Lateral1,  TunnelRow::Rotation0,
                             TunnelRow::Rotation1, TunnelRow::Rotation2, TunnelRow::Bottom,
                             TunnelRow::Hold};
  for (int r = 0; r < 7; ++r) {
    EXPECT_EQ(rows.meta[r].kind, kinds[r]) << r;
    EXPECT_EQ(rows.problem.rows[r].key, tunnel_key(keys[r])) << r;
    EXPECT_EQ(rows.problem.rows[r].equality, r < 5) << r;
  }
  // Bottom: depth + n·dp <= upper, i.e. -n·dp >= depth - upper; hold: n·dp >= lower - depth.
  EXPECT_NEAR(rows.problem.rows[5].b, 0.2 - 0.3, 1e-15);
  EXPECT_NEAR(rows.problem.rows[6].b, 0.1 - 0.2, 1e-15);
}

// Inside the lesion the tip advances while |F_p| exceeds the tissue's resistance R = k_c·crush_length
// (docs/penetration.md), to where |F_p| = R, by at most eq. 5's |F_p|/k_c per 1 ms (scaled by dt)
// and the give speed; below R the bottom stays.
TEST(TunnelLimits, DepthGrowsToTheResistance) {
  const Model m = lesion_model();
  const Params& p = m.defaults;
  const Material& mat = p.materials[0];
  const double resistance = insertion_resistance(mat, 0.3);
  ASSERT_NEAR(resistance, 10.0 * mat.crush_length, 1e-12);
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  s.tunnel = straight_down(0.3);
  s.graphic = probe_at(Vec3(0, 0, -0.3));
  s.interaction = InteractionState::Inserting;
  int advanced = 0, held = 0;
  for (const double dt : {0.001, 0.00025}) {
    for (const double along : {1.5, 2.001, 2.01, 2.05, 4.0, 8.0}) {  // mm of hand below the graphic tip
      const TunnelLimits l = tunnel_limits(m, p, s, probe_at(Vec3(0, 0, -0.3 - along)), dt);
      const double f_p = mat.k_e * along;
      double expected = 0.3;
      if (f_p > resistance) {
        expected += std::min({along - resistance / mat.k_e,
                              f_p / mat.k_c.at(s.tunnel.depth0 + 0.3) * dt / m.settings.reference_dt,
                              m.settings.max_give_speed * dt});
        ++advanced;
      } else {
        ++held;
      }
      EXPECT_NEAR(l.upper, expected, 1e-12) << along << " mm at dt " << dt;
      EXPECT_EQ(l.lower, 0.3);
      EXPECT_EQ(l.tunnel, &s.tunnel);
      EXPECT_EQ(s.interaction, InteractionState::Inserting);
    }
  }
  EXPECT_GT(advanced, 4);
  EXPECT_GT(held, 1);
  // The lesion's bottom is a hard stop.
  s.tunnel.depth = s.tunnel.max_depth - 0.01;
  const TunnelLimits deep = tunnel_limits(m, p, s, probe_at(Vec3(0, 0, -0.3 - 500.0)), 0.001);
  EXPECT_EQ(deep.upper, s.tunnel.max_depth);
}

// Extraction (eqs. 8-9): a pull beyond F_e* switches to extracting and lets the tip out by eq. 5's
// rate; a weaker pull holds it.
TEST(TunnelLimits, ExtractionBeyondFeStar) {
  const Model m = lesion_model();
  const Params& p = m.defaults;
  const Material& mat = p.materials[0];
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  s.tunnel = straight_down(1.0);
  s.graphic = probe_at(Vec3(0, 0, -1.0));
  s.interaction = InteractionState::Inserting;
  const TunnelLimits held = tunnel_limits(m, p, s, probe_at(Vec3(0, 0, -1.0 + 0.8)), 0.001);  // 0.8 N < F_e*
  EXPECT_EQ(s.interaction, InteractionState::Inserting);
  EXPECT_EQ(held.lower, 1.0);
  EXPECT_EQ(held.upper, 1.0);
  const double along = 1.6;  // 1.6 N > F_e*
  const TunnelLimits out = tunnel_limits(m, p, s, probe_at(Vec3(0, 0, -1.0 + along)), 0.001);
  EXPECT_EQ(s.interaction, InteractionState::Extracting);
  const double delta = std::min(mat.k_e * along / mat.k_c.at(1.0), along - mat.f_e_star / mat.k_e);
  EXPECT_NEAR(out.lower, 1.0 - delta, 1e-12);
  EXPECT_EQ(out.upper, 1.0);
}

// Entry (eqs. 3-4): the tip must have touched caries and the push along the tip axis must exceed F_p*;
// then the tunnel opens at the tip with n frozen along the tool's -z and its bottom at the lesion's.
TEST(Penetration, EntersOnlyAboveFpStarOnCaries) {
  const Model m = lesion_model();
  const Params& p = m.defaults;
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  const Pose g = probe_at(Vec3(0, 0, kTip - 0.1));
  s.graphic = g;
  s.anchors[0].active = true;
  s.tip = TipContact{-1, 0, 0.1};
  EXPECT_FALSE(try_enter_penetration(m, p, s, probe_at(g.p - Vec3(0, 0, 5.0)))) << "no caries under the tip";
  s.tip.lesion = 0;
  EXPECT_FALSE(try_enter_penetration(m, p, s, probe_at(g.p - Vec3(0, 0, 2.9)))) << "2.9 N < F_p*";
  EXPECT_FALSE(try_enter_penetration(m, p, s, probe_at(g.p + Vec3(5.0, 0, 0)))) << "sideways is no push";
  EXPECT_EQ(s.interaction, InteractionState::Free);
  ASSERT_TRUE(try_enter_penetration(m, p, s, probe_at(g.p - Vec3(0, 0, 3.1))));
  EXPECT_EQ(s.interaction, InteractionState::Inserting);
  EXPECT_EQ(s.tunnel.entry, g.p);
  EXPECT_NEAR((s.tunnel.n + Vec3::UnitZ()).norm(), 0.0, 1e-15);
  EXPECT_EQ(s.tunnel.depth, 0.0);
  EXPECT_NEAR(s.tunnel.depth0, 0.1, 0.01) << "the apex's depth below the lesion's surface";
  EXPECT_EQ(s.tunnel.lesion, 0);
  EXPECT_FALSE(s.anchors[0].active) << "anchors are released";
  // The apex may travel until it leaves the lesion at its bottom (1.5 mm below the surface).
  EXPECT_NEAR(s.tunnel.max_depth, 1.5 + g.p.z() - kTip, 1e-4);
}

// The five displayed spheres: one on the axis below the tip, four around it.
TEST(TunnelSpheres, FiveAroundTheTip) {
  const Model m = lesion_model();
  State state(m, probe_at(Vec3(0, 0, 5)));
  StateImpl& s = state_impl(state);
  s.tunnel = straight_down(0.4);
  s.tunnel.depth0 = 0.1;
  s.interaction = InteractionState::Inserting;
  TunnelSpheres out;
  tunnel_spheres(m, s, out);
  ASSERT_TRUE(out.active);
  const Vec3 tip = s.tunnel.n * 0.4;
  EXPECT_NEAR((out.centers[0] - (tip + s.tunnel.n * (kTip + out.radii[0]))).norm(), 0.0, 1e-12);
  for (int j = 1; j < 5; ++j) {
    EXPECT_NEAR((out.centers[j] - tip).dot(s.tunnel.n), 0.0, 1e-12) << j;
    EXPECT_NEAR((out.centers[j] - tip).norm(), kTip + out.radii[j], 1e-12) << j;
  }
  EXPECT_NEAR((out.centers[1] + out.centers[2] - 2.0 * tip).norm(), 0.0, 1e-12);
  EXPECT_NEAR(out.max_depth, 0.1 + 1.4, 1e-12);
  s.interaction = InteractionState::Sliding;
  tunnel_spheres(m, s, out);
  EXPECT_FALSE(out.active);
}

// Through the step: once inside, a hand moved sideways and turned leaves the tip on the axis; the
// feedback is eq. 6 (k_p, the device's maximum stiffness) and eq. 7 (k_θ).
TEST(Penetration, TheStepHoldsTheTipOnTheAxis) {
  const Model m = lesion_model();
  State s(m, probe_at(Vec3(0, 0, 2)));
  StepOutput out;
  double z = 2.0;
  for (int i = 0; i < 3000 && out.state != InteractionState::Inserting; ++i) {
    z -= 0.01;
    out = step(m, s, HapticInput{probe_at(Vec3(0, 0, z)), 0.001});
  }
  ASSERT_EQ(out.state, InteractionState::Inserting);
  const Vec3 entry = out.tunnel.entry, n = out.tunnel.axis;
  const Pose hand{out.graphic.p + Vec3(0.8, -0.5, 0.0), Quat(Eigen::AngleAxisd(0.1, Vec3::UnitX()))};
  for (int i = 0; i < 20; ++i) out = step(m, s, HapticInput{hand, 0.001});
  ASSERT_TRUE(penetrating(out.state));
  const Vec3 off = out.graphic.p - entry;
  EXPECT_NEAR((off - n * off.dot(n)).norm(), 0.0, 1e-9) << "the tip is on the axis";
  EXPECT_NEAR(rotation_vector(out.graphic.q).norm(), 0.0, 1e-6) << "the orientation is locked";
  EXPECT_NEAR((out.force - m.defaults.limits.max_stiffness * (out.graphic.p - hand.p)).norm(), 0.0, 1e-9);
  EXPECT_GT(out.force.norm(), 0.9 * m.defaults.limits.max_stiffness * 0.8);
  EXPECT_NEAR(out.torque.norm(), m.defaults.materials[0].k_theta * 0.1, 1e-6);
}

}  // namespace
}  // namespace cariesim
