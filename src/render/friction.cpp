// Friction on caries in the sliding state (paper §3.2, Figs. 10-11; docs/design.md §4 step 4).
//
// A loaded contact region on frictional tissue sticks: its tool point is held at an anchor in the
// tangent plane by two equality rows t_j·(dp + dθ × a) = t_j·(anchor - x). Their multipliers are the
// tangential force. While it stays inside the static cone |f_t| <= mu_s·f_n the anchor holds; once it
// leaves, the contact slips: the anchor moves toward where the tool would go so that the tangential
// force falls to the dynamic cone mu_d·f_n, and the build-up starts again. This stick-slip cycle is
// the saw-tooth of the paper's force signals. Anisotropic friction (paper §2.1) uses an elliptic cone
// with other coefficients along the material's direction than across it.
//
// The stages here: attach_anchors (before each solve's rows), build_friction_rows (the row builder,
// owner of the friction rows' key space), decide_slips and apply_slips (between the final solve of a
// sub-step and its re-solve), create_anchors (at the end of a sliding cycle).
#include "render/friction.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cariesim::detail {

namespace {

constexpr double kMinNormalForce = 1e-6;     // N: below this a contact carries no friction
constexpr double kRigidSlipStiffness = 1e3;  // N/mm: a rigid row's share of the slip stiffness
// mm: a sticking tool point sits on its anchor (its rows hold it there); one this far from it in the
// tangent plane is no longer held by friction (the tool was carried off, e.g. while lagging) and
// releases, so that an anchor can never drag the tool.
constexpr double kMaxAnchorOffset = 0.5;

int find_region(const RegionSet& regions, const FrictionAnchor& a) {
  for (int r = 0; r < regions.count; ++r) {
    const Region& reg = regions.regions[r];
    if (reg.object == a.object && (reg.tool_point_local - a.point_local).norm() < kRegionRadius) return r;
  }
  return -1;
}

// The cone's axes in the tangent plane and the coefficients along them.
struct Cone {
  Vec3 u, v;
  double mu_s_u, mu_s_v, mu_d_u, mu_d_v;
};

Cone cone_of(const Material& mat, const Vec3& n) {
  Cone c;
  const Vec3 dir = mat.aniso_dir - n * n.dot(mat.aniso_dir);
  if (dir.norm() > 1e-9) {
    c.u = dir.normalized();
    c.v = n.cross(c.u);
    c.mu_s_u = mat.mu_s_along;
    c.mu_d_u = mat.mu_d_along;
  } else {
    tangent_basis(n, c.u, c.v);
    c.mu_s_u = mat.mu_s;
    c.mu_d_u = mat.mu_d;
  }
  c.mu_s_v = mat.mu_s;
  c.mu_d_v = mat.mu_d;
  // A dynamic coefficient above the static one would make slipping harder than sticking.
  c.mu_d_u = std::min(c.mu_d_u, c.mu_s_u);
  c.mu_d_v = std::min(c.mu_d_v, c.mu_s_v);
  return c;
}

// Elliptic cone measure: the normal force at which (f_u, f_v) lies exactly on the cone.
double cone_measure(double f_u, double f_v, double mu_u, double mu_v) {
  const auto term = [](double f, double mu) {
    if (std::abs(f) < 1e-15) return 0.0;
    return mu > 1e-12 ? (f / mu) * (f / mu) : std::numeric_limits<double>::infinity();
  };
  return std::sqrt(term(f_u, mu_u) + term(f_v, mu_v));
}

}  // namespace

void attach_anchors(const RegionSet& regions, const Pose& g0, Anchors& anchors) {
  for (FrictionAnchor& a : anchors) {
    if (!a.active) continue;
    // The anchor's region is gone: the tool left the surface.
    const int r = find_region(regions, a);
    if (r < 0) {
      a.active = false;
      continue;
    }
    a.region = static_cast<int16_t>(r);
    // The anchor lies in the contact's tangent plane: drop the offset along the normal (a tool
    // sinking into compliant tissue leaves its anchor above it), which a later, tilted normal would
    // otherwise turn into a sideways pull.
    const Vec3 x = g0.transform(a.point_local);
    const Vec3& n = regions.regions[r].normal;
    a.anchor -= n * n.dot(a.anchor - x);
    if ((a.anchor - x).norm() > kMaxAnchorOffset) a.active = false;
  }
}

void build_friction_rows(const Anchors& anchors, const RegionSet& regions, const Pose& g0, RowSet& rows) {
  for (int k = 0; k < kMaxAnchors; ++k) {
    const FrictionAnchor& a = anchors[k];
    if (!a.active) continue;
    // Two tangent rows holding the tool point x at the anchor.
    const Vec3 x = g0.transform(a.point_local);
    const Vec3 lever = x - g0.p;
    const Vec3& n = regions.regions[a.region].normal;
    Vec3 t[2];
    tangent_basis(n, t[0], t[1]);
    for (int j = 0; j < 2; ++j) {
      QpRow row;
      row.a.head<3>() = t[j];
      row.a.tail<3>() = lever.cross(t[j]);
      row.b = t[j].dot(a.anchor - x);
      row.equality = true;
      row.key = friction_key(k, j);
      if (!rows.add(row, RowMeta{RowKind::Friction, a.region, static_cast<int16_t>(k), -1})) return;
      rows.anchor_rows[k][j] = static_cast<int8_t>(rows.problem.row_count - 1);
    }
  }
}

void decide_slips(const Params& p, const Anchors& anchors, const RegionSet& regions, const RowSet& rows,
                  const Solution& solution, const Pose& g0, const Mat6& G, SlipPlan& plan) {
  plan.changed = 0;
  plan.slipped = 0;
  // Contradicting rows (e.g. two anchors on one rigid tool that no motion satisfies together): the
  // multipliers are no forces, so no cone can be judged on them. Every anchor lets go; the tool sticks
  // again where it ends this cycle.
  const bool infeasible = (solution.flags & kFlagInfeasible) != 0;
  // Where the tool would go without its anchors: the solve's unconstrained target.
  const Pose free_pose = apply_displacement(g0, rows.problem.x_target);
  for (int k = 0; k < kMaxAnchors; ++k) {
    const FrictionAnchor& a = anchors[k];
    plan.action[k] = SlipPlan::Action::Keep;
    const int row0 = rows.anchor_rows[k][0], row1 = rows.anchor_rows[k][1];
    if (!a.active || row0 < 0 || row1 < 0) continue;
    if (infeasible) {
      plan.action[k] = SlipPlan::Action::Release;
      ++plan.changed;
      continue;
    }
    const int r = rows.meta[row0].region;
    const Region& reg = regions.regions[r];
    const double f_n = solution.region_force[r];
    // No normal load: the contact is separating and cannot hold.
    if (f_n <= kMinNormalForce) {
      plan.action[k] = SlipPlan::Action::Release;
      ++plan.changed;
      continue;
    }
    const Vec3 t0 = rows.problem.rows[row0].a.head<3>(), t1 = rows.problem.rows[row1].a.head<3>();
    const Vec3 f_t = solution.qp.lambda[row0] * t0 + solution.qp.lambda[row1] * t1;
    const Cone cone = cone_of(p.materials[reg.material], reg.normal);
    const double f_u = f_t.dot(cone.u);
    const double f_v = f_t.dot(cone.v);
    // Inside the static cone: stick.
    if (cone_measure(f_u, f_v, cone.mu_s_u, cone.mu_s_v) <= f_n) continue;

    // Slip: scale the tangential load onto the dynamic cone by moving the anchor toward where the
    // unconstrained tool would be. The load is linear in the anchor offset with the effective
    // tangential stiffness seen at this point: the coupling (translation and rotation in series) plus
    // every loaded contact row that resists motion along the load (tissue stiffness, or
    // kRigidSlipStiffness for rigid rows). Without the contacts' share a tool pressed sideways into
    // stiff tissue would throw its anchor far past where the tissue lets it go.
    const double q_d = cone_measure(f_u, f_v, cone.mu_d_u, cone.mu_d_v);
    const double scale = std::isfinite(q_d) && q_d > 0.0 ? std::min(1.0, f_n / q_d) : 0.0;
    const double f_t_norm = f_t.norm();
    const Vec3 dir = f_t / f_t_norm;
    const Vec3 lever = g0.q * a.point_local;
    const double k_t = G(0, 0), k_r = G(3, 3);
    double k_eff = 1.0 / (1.0 / k_t + lever.cross(dir).squaredNorm() / k_r);
    for (int row = 0; row < rows.problem.row_count; ++row) {
      if (rows.meta[row].kind != RowKind::Contact || solution.qp.lambda[row] <= 0.0) continue;
      const QpRow& qr = rows.problem.rows[row];
      const double along = qr.a.head<3>().dot(dir);
      k_eff += along * along * (qr.compliance > 0.0 ? 1.0 / qr.compliance : kRigidSlipStiffness);
    }
    // The anchor moves toward where the load pulls it, but never further than the tool point would
    // go without it (its place at the solve's target, in the tangent plane): friction only resists.
    Vec3 shift = -(1.0 - scale) * f_t / k_eff;
    Vec3 reach = free_pose.transform(a.point_local) - a.anchor;
    reach -= reg.normal * reg.normal.dot(reach);
    if (shift.norm() > reach.norm()) shift *= reach.norm() / shift.norm();
    plan.action[k] = SlipPlan::Action::Slip;
    plan.anchor[k] = a.anchor + shift;
    ++plan.changed;
    ++plan.slipped;
  }
}

void apply_slips(const SlipPlan& plan, Anchors& anchors) {
  for (int k = 0; k < kMaxAnchors; ++k) {
    if (plan.action[k] == SlipPlan::Action::Release) anchors[k].active = false;
    if (plan.action[k] == SlipPlan::Action::Slip) anchors[k].anchor = plan.anchor[k];
  }
}

void create_anchors(const Params& p, const RegionSet& regions, const Solution& solution, const Pose& g,
                    Anchors& anchors) {
  for (int r = 0; r < regions.count; ++r) {
    const Region& reg = regions.regions[r];
    if (!p.materials[reg.material].frictional() || solution.region_force[r] <= kMinNormalForce) continue;
    // One anchor per region: skip a region that already has one.
    bool anchored = false;
    for (const FrictionAnchor& a : anchors)
      anchored = anchored || (a.active && a.object == reg.object &&
                              (reg.tool_point_local - a.point_local).norm() < kRegionRadius);
    if (anchored) continue;
    for (FrictionAnchor& a : anchors) {
      if (a.active) continue;
      a.active = true;
      a.object = reg.object;
      a.point_local = reg.tool_point_local;
      a.anchor = g.transform(reg.tool_point_local);
      a.region = static_cast<int16_t>(r);
      break;
    }
  }
}

void release_anchors(Anchors& anchors) {
  for (FrictionAnchor& a : anchors) a.active = false;
}

}  // namespace cariesim::detail
