// The friction stages (src/render/friction.cpp), tested directly on a hand-made contact region: the
// anchors laid into the tangent plane, the stick rows, the Coulomb cone (stick, slip onto the dynamic
// cone, release) and the anchors' creation. Closed form: one compliant contact row along +z and the
// anchor at the tool-frame origin, so the normal force is the series spring force and the tangential
// force is the coupling's pull.
#include <gtest/gtest.h>

#include <cmath>

#include "render/render_support.hpp"
#include "render/friction.hpp"
#include "render/solve.hpp"
#include "render/stages.hpp"

namespace cariesim {
namespace {

using namespace detail;

// One compliant region on object 0 (normal +z, tool point at the tool-frame origin), its contact row,
// one anchor, and the coupling pulling the tool `pull` sideways and `push` down.
struct Rig {
  Params params;
  RegionSet regions;
  Anchors anchors{};
  RowSet rows;
  Solution solution;
  QpSolver solver;
  SlipPlan plan;
  Mat6 G = Mat6::Identity();
  Vec6 target = Vec6::Zero();
  Pose g0;
  double k = 1.0;  // N/mm, the tissue

  Rig(const Material& material, const Vec3& pull, double push) {
    params.materials = {material};
    k = material.stiffness;
    G.diagonal().tail<3>().setConstant(150.0);  // N·mm/rad; translation 1 N/mm
    target.head<3>() = pull - push * Vec3::UnitZ();
    regions.count = 1;
    Region& reg = regions.regions[0];
    reg.tool_point_local = Vec3::Zero();
    reg.normal = Vec3::UnitZ();
    reg.compliant = true;
    anchors[0].active = true;
    anchors[0].object = 0;
  }

  // One solve at g0: anchors attached, then the contact row (the tool at the surface) and the stick rows.
  void solve() {
    attach_anchors(regions, g0, anchors);
    rows.clear(G, target);
    QpRow contact;
    contact.a.head<3>() = Vec3::UnitZ();
    contact.compliance = 1.0 / k;
    contact.key = 1;
    ASSERT_TRUE(rows.add(contact, RowMeta{RowKind::Contact, 0, -1, 0}));
    build_friction_rows(anchors, regions, g0, rows);
    solve_rows(rows, regions, solver, solution);
  }

  // The tangential force of anchor 0's rows (N).
  [[nodiscard]] Vec3 tangential() const {
    const int r0 = rows.anchor_rows[0][0], r1 = rows.anchor_rows[0][1];
    return solution.qp.lambda[r0] * rows.problem.rows[r0].a.head<3>() +
           solution.qp.lambda[r1] * rows.problem.rows[r1].a.head<3>();
  }
};

// The normal force of the rig: the hand `push` below the surface through the coupling (1 N/mm) and
// the tissue (k) in series.
double normal_force(double push, double k) { return push / (1.0 + 1.0 / k); }

// An anchor lies in its region's tangent plane at g0; one whose region is gone is released.
TEST(AttachAnchors, LaysAnchorsIntoTheTangentPlaneAndReleasesLostOnes) {
  RegionSet regions;
  regions.count = 1;
  regions.regions[0].normal = Vec3::UnitZ();
  regions.regions[0].object = 0;
  Anchors anchors{};
  anchors[0] = FrictionAnchor{Vec3::Zero(), Vec3(0.2, 0.1, 0.3), 0, -1, true};
  anchors[1] = FrictionAnchor{Vec3::Zero(), Vec3(0.2, 0.1, 0.3), 1, -1, true};   // object 1: no region
  anchors[2] = FrictionAnchor{Vec3(0, 0, 3), Vec3(0.2, 0.1, 0.3), 0, -1, true};  // 3 mm up the tool
  const Pose g0{Vec3(0, 0, 0.1), Quat::Identity()};
  attach_anchors(regions, g0, anchors);
  EXPECT_TRUE(anchors[0].active);
  EXPECT_EQ(anchors[0].region, 0);
  EXPECT_NEAR((anchors[0].anchor - Vec3(0.2, 0.1, 0.1)).norm(), 0.0, 1e-15);
  EXPECT_FALSE(anchors[1].active);
  EXPECT_FALSE(anchors[2].active) << "farther from the region's tool point than kRegionRadius";

  // An anchor its tool point was carried 0.6 mm away from no longer holds it.
  anchors[3] = FrictionAnchor{Vec3::Zero(), Vec3(0.6, 0.0, 0.1), 0, -1, true};
  attach_anchors(regions, g0, anchors);
  EXPECT_FALSE(anchors[3].active) << "0.6 mm from its tool point";
}

// Two tangent equality rows per anchor hold the tool point at the anchor: t_j·(dp + dθ × a) =
// t_j·(anchor - x), keyed in the friction key space, found through anchor_rows.
TEST(FrictionRows, HoldTheToolPointAtTheAnchor) {
  RegionSet regions;
  regions.count = 1;
  const Vec3 n = Vec3(0.3, -0.2, 1.0).normalized();
  regions.regions[0].normal = n;
  regions.regions[0].tool_point_local = Vec3(0, 0, 0.5);
  Anchors anchors{};
  anchors[3] = FrictionAnchor{Vec3(0, 0, 0.5), Vec3(0.1, 0.2, 0.3), 0, -1, true};
  const Pose g0{Vec3(0.05, 0.0, 0.0), Quat(Eigen::AngleAxisd(0.4, Vec3(1, 1, 0).normalized()))};
  attach_anchors(regions, g0, anchors);
  RowSet rows;
  rows.clear(Mat6::Identity(), Vec6::Zero());
  build_friction_rows(anchors, regions, g0, rows);
  ASSERT_EQ(rows.problem.row_count, 2);
  const Vec3 x = g0.transform(anchors[3].point_local);
  for (int j = 0; j < 2; ++j) {
    const int index = rows.anchor_rows[3][j];
    ASSERT_EQ(index, j);
    const QpRow& row = rows.problem.rows[index];
    const Vec3 t = row.a.head<3>();
    EXPECT_TRUE(row.equality);
    EXPECT_EQ(row.key, friction_key(3, j));
    EXPECT_NEAR(t.norm(), 1.0, 1e-12);
    EXPECT_NEAR(t.dot(n), 0.0, 1e-12);
    EXPECT_NEAR((Vec3(row.a.tail<3>()) - (x - g0.p).cross(t)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(row.b, t.dot(anchors[3].anchor - x), 1e-12);
    EXPECT_EQ(rows.meta[index].kind, RowKind::Friction);
    EXPECT_EQ(rows.meta[index].anchor, 3);
    EXPECT_EQ(rows.meta[index].region, 0);
  }
  EXPECT_NEAR(rows.problem.rows[0].a.head<3>().dot(rows.problem.rows[1].a.head<3>()), 0.0, 1e-12);
  EXPECT_EQ(rows.anchor_rows[0][0], -1) << "an inactive anchor has no rows";
}

// Inside the static cone the contact sticks: the tangential force is the coupling's pull and the
// anchor stays.
TEST(FrictionCone, SticksInsideTheStaticCone) {
  Rig rig(test::soft(1.0, 0.5, 0.3), Vec3(0.2, 0, 0), 1.0);  // |f_t| 0.2 N <= 0.5 x 0.5 N
  rig.solve();
  ASSERT_EQ(rig.solution.flags, 0u);
  EXPECT_NEAR(rig.solution.region_force[0], normal_force(1.0, 1.0), 1e-9);
  EXPECT_NEAR(rig.tangential().norm(), 0.2, 1e-9);
  decide_slips(rig.params, rig.anchors, rig.regions, rig.rows, rig.solution, rig.g0, rig.G, rig.plan);
  EXPECT_EQ(rig.plan.action[0], SlipPlan::Action::Keep);
  EXPECT_EQ(rig.plan.changed, 0);
  EXPECT_EQ(rig.plan.slipped, 0);
}

// Beyond the static cone the contact slips: the plan moves the anchor (the anchors themselves move
// only when the plan is applied, between two solves) so that the next solve's tangential force lies
// on the dynamic cone, mu_d f_n.
TEST(FrictionCone, SlipsOntoTheDynamicCone) {
  const double mu_s = 0.5, mu_d = 0.3;
  Rig rig(test::soft(1.0, mu_s, mu_d), Vec3(0.4, 0, 0), 1.0);  // |f_t| 0.4 N > 0.25 N
  rig.solve();
  const double f_n = normal_force(1.0, 1.0);
  ASSERT_GT(rig.tangential().norm(), mu_s * f_n);
  decide_slips(rig.params, rig.anchors, rig.regions, rig.rows, rig.solution, rig.g0, rig.G, rig.plan);
  ASSERT_EQ(rig.plan.action[0], SlipPlan::Action::Slip);
  EXPECT_EQ(rig.plan.changed, 1);
  EXPECT_EQ(rig.plan.slipped, 1);
  EXPECT_EQ(rig.anchors[0].anchor, Vec3::Zero()) << "deciding moves nothing";
  // The coupling alone resists tangential motion here (lever 0, contact row along the normal), so
  // the anchor moves by (1 - mu_d f_n / |f_t|) |f_t| / k_t toward the pull.
  EXPECT_NEAR((rig.plan.anchor[0] - Vec3(0.4 - mu_d * f_n, 0, 0)).norm(), 0.0, 1e-9);
  apply_slips(rig.plan, rig.anchors);
  EXPECT_EQ(rig.anchors[0].anchor, rig.plan.anchor[0]);
  rig.solve();
  EXPECT_NEAR(rig.solution.region_force[0], f_n, 1e-9);
  EXPECT_NEAR(rig.tangential().norm(), mu_d * f_n, 1e-9);
}

// Without normal load (the tool lifts off) an anchor cannot hold: released.
TEST(FrictionCone, ReleasesWithoutNormalLoad) {
  Rig rig(test::soft(1.0, 0.5, 0.3), Vec3(0.1, 0, 0), -1.0);  // pulled up, off the surface
  rig.solve();
  EXPECT_EQ(rig.solution.region_force[0], 0.0);
  decide_slips(rig.params, rig.anchors, rig.regions, rig.rows, rig.solution, rig.g0, rig.G, rig.plan);
  EXPECT_EQ(rig.plan.action[0], SlipPlan::Action::Release);
  EXPECT_EQ(rig.plan.changed, 1);
  EXPECT_EQ(rig.plan.slipped, 0);
  apply_slips(rig.plan, rig.anchors);
  EXPECT_FALSE(rig.anchors[0].active);
}

// Rows that contradict each other give multipliers that are no forces: every anchor lets go instead
// of slipping by them (two anchors on one tool once threw each other 110 mm off and dragged it away).
TEST(FrictionCone, InfeasibleSolveReleasesEveryAnchor) {
  Rig rig(test::soft(1.0, 0.5, 0.3), Vec3(0.4, 0, 0), 1.0);
  rig.solve();
  rig.solution.flags |= kFlagInfeasible;
  decide_slips(rig.params, rig.anchors, rig.regions, rig.rows, rig.solution, rig.g0, rig.G, rig.plan);
  EXPECT_EQ(rig.plan.action[0], SlipPlan::Action::Release);
  EXPECT_EQ(rig.plan.slipped, 0);
}

// Friction only resists: a slip never moves the anchor further than the tool point would go without
// it (its place at the solve's target), however large the tangential load.
TEST(FrictionCone, SlipNeverCarriesTheAnchorPastTheFreeTool) {
  Rig rig(test::soft(1.0, 0.5, 0.3), Vec3(0.4, 0, 0), 1.0);
  rig.solve();
  const int r0 = rig.rows.anchor_rows[0][0], r1 = rig.rows.anchor_rows[0][1];
  rig.solution.qp.lambda[r0] *= 1000.0;  // a load no coupling explains
  rig.solution.qp.lambda[r1] *= 1000.0;
  decide_slips(rig.params, rig.anchors, rig.regions, rig.rows, rig.solution, rig.g0, rig.G, rig.plan);
  ASSERT_EQ(rig.plan.action[0], SlipPlan::Action::Slip);
  const Vec3 free_point = apply_displacement(rig.g0, rig.rows.problem.x_target).transform(Vec3::Zero());
  Vec3 reach = free_point - rig.anchors[0].anchor;
  reach.z() = 0.0;
  EXPECT_LE((rig.plan.anchor[0] - rig.anchors[0].anchor).norm(), reach.norm() + 1e-12);
  EXPECT_NEAR(reach.norm(), 0.4, 1e-9);
}

// An anisotropic cone: the same pull slips along the material's direction (mu_s_along) and sticks
// across it (mu_s).
TEST(FrictionCone, AnisotropicConeDependsOnTheDirection) {
  Material mat = test::soft(1.0, 0.8, 0.6);
  mat.aniso_dir = Vec3::UnitX();
  mat.mu_s_along = 0.1;
  mat.mu_d_along = 0.05;
  const auto decide = [&](const Vec3& pull) {
    Rig rig(mat, pull, 1.0);
    rig.solve();
    decide_slips(rig.params, rig.anchors, rig.regions, rig.rows, rig.solution, rig.g0, rig.G, rig.plan);
    return rig.plan.action[0];
  };
  EXPECT_EQ(decide(Vec3(0.2, 0, 0)), SlipPlan::Action::Slip);  // 0.2 N > 0.1 x 0.5 N
  EXPECT_EQ(decide(Vec3(0, 0.2, 0)), SlipPlan::Action::Keep);  // 0.2 N <= 0.8 x 0.5 N
}

// Anchors are created for frictional regions under load only, one per region, at the region's tool
// point at g.
TEST(CreateAnchors, OnlyOnLoadedFrictionalRegionsOncePerRegion) {
  Params p;
  p.materials = {test::soft(1.0, 0.5, 0.3), test::soft(1.0)};
  RegionSet regions;
  regions.count = 3;
  for (int r = 0; r < 3; ++r) {
    regions.regions[r].object = static_cast<uint16_t>(r);
    regions.regions[r].tool_point_local = Vec3(0, 0, 0.5 * r);
  }
  regions.regions[1].material = 1;  // frictionless
  Solution solution;
  solution.region_force = {};
  solution.region_force[0] = 0.4;
  solution.region_force[1] = 0.4;
  solution.region_force[2] = 0.0;  // frictional, not loaded
  const Pose g{Vec3(1, 2, 3), Quat(Eigen::AngleAxisd(0.5, Vec3::UnitY()))};
  Anchors anchors{};
  create_anchors(p, regions, solution, g, anchors);
  int active = 0;
  for (const FrictionAnchor& a : anchors) active += a.active;
  ASSERT_EQ(active, 1);
  EXPECT_EQ(anchors[0].object, 0);
  EXPECT_EQ(anchors[0].region, 0);
  EXPECT_NEAR((anchors[0].anchor - g.p).norm(), 0.0, 1e-12);
  create_anchors(p, regions, solution, g, anchors);
  active = 0;
  for (const FrictionAnchor& a : anchors) active += a.active;
  EXPECT_EQ(active, 1) << "a region keeps its one anchor";
  release_anchors(anchors);
  for (const FrictionAnchor& a : anchors) EXPECT_FALSE(a.active);
}

}  // namespace
}  // namespace cariesim
