// One bounded optimisation of the graphic tool (paper eq. 1, docs/design.md §4 steps 1-4), the stages of
// stages.hpp in order:
//   1. collision: every sphere pair the tool can reach while moving by at most the sub-step's bound,
//      measured at g0;
//   2. one solve: regions, anchors, rows (contact, friction, tunnel), the QP; the pairs whose rows
//      bore load (compliant, or rigid of a capped tool leaf) are carried to the next solve
//      (hysteresis, CarriedPairs);
//   3. slip: the friction cone at the final solve (the motion ends in this sub-step); slipped or
//      released anchors change the rows, so they are solved once more;
//   4. re-check collision at the solution: a new rigid overlap brings its pair in and the sub-step is
//      solved again; if overlaps remain, the step is shortened (bisection) until it is clear.
// The tangent-plane rows are conservative for translations, so step 4 only catches the second-order
// effect of rotations and pairs outside the margin; it rarely runs.
#include "render/substep.hpp"

#include <algorithm>
#include <cmath>

#include "render/state_impl.hpp"
#include "render/tunnel.hpp"

namespace cariesim::detail {

Vec6 config_difference(const Pose& to, const Pose& from) {
  Vec6 d;
  d.head<3>() = to.p - from.p;
  d.tail<3>() = rotation_vector(to.q * from.q.conjugate());
  return d;
}

Pose apply_displacement(const Pose& g, const Vec6& d) {
  Pose out;
  out.p = g.p + d.head<3>();
  out.q = (quat_from_rotation_vector(d.tail<3>()) * g.q).normalized();
  return out;
}

namespace {

// Stages 2-4 of one solve at g0 (the pairs are measured there): regions, anchors, rows, QP. Returns
// the displacement (zero when infeasible).
Vec6 solve_once(const Model& m, const Params& p, StateImpl& s, const Pose& g0, const SubstepRequest& req,
                StepTrace& trace) {
  s.collision.budget.charge(kSolveWork);
  build_regions(m, s.constants, s.pairs, s.regions);
  if (req.friction) attach_anchors(s.regions, g0, s.anchors);
  s.rows.clear(req.G, req.target);
  trace.contacts = build_contact_rows(m, p, s.pairs, s.regions, req.hold_only, s.contact_rows, s.rows);
  if (req.friction) build_friction_rows(s.anchors, s.regions, g0, s.rows);
  if (req.tunnel != nullptr) build_tunnel_rows(*req.tunnel, g0, s.rows);
  if (req.engaged != nullptr) build_engagement_rows(*req.engaged, g0, s.rows);
  if (s.rows.full) trace.flags |= kFlagQpRowsFull;
  solve_rows(s.rows, s.regions, s.solver, s.solution);
  trace.flags |= s.solution.flags;
  remember_loaded_pairs(s.pairs, s.regions, s.rows, s.solution, req.tunnel != nullptr,
                        s.collision.contacts.capped(), s.carried);
  return s.solution.d;
}

// The factor (<= 1) that shortens d onto the sub-step's bounds.
double bound_scale(const Vec6& d, const SubstepRequest& req) {
  const double trans = d.head<3>().norm(), rot = d.tail<3>().norm();
  return std::min({1.0, trans > 0.0 ? req.trans_bound / trans : 1.0, rot > 0.0 ? req.rot_bound / rot : 1.0});
}

}  // namespace

bool slip_anchors(const Params& p, StateImpl& s, const Pose& g0, const Mat6& G, StepTrace& trace) {
  decide_slips(p, s.anchors, s.regions, s.rows, s.solution, g0, G, s.slips);
  if (s.slips.changed == 0) return false;
  trace.slips += s.slips.slipped;
  apply_slips(s.slips, s.anchors);
  return true;
}

Pose solve_substep(const Model& m, const Params& p, StateImpl& s, const Pose& g0, const SubstepRequest& req,
                   StepTrace& trace, bool& reached, SubstepMotion* wanted) {
  // Stage 1: pairs within reach of this sub-step's largest motion, measured at g0.
  set_leaf_margins(m, req.trans_bound, req.rot_bound, s.collision);
  if (!collect_pairs(m, s.constants, s.collision, g0, req.mask, s.pairs)) trace.flags |= kFlagContactOverflow;
  if (req.tunnel == nullptr) mark_carried_pairs(m, s.constants, s.carried, req.mask, s.pairs);

  const double tol = m.settings.rigid_tolerance;
  const int max_passes = m.settings.max_rechecks + 2;
  bool friction_checked = !req.friction;
  Vec6 d = Vec6::Zero();
  reached = true;
  for (int pass = 0; pass < max_passes; ++pass) {
    // Stages 2-4, then the motion shortened onto the trust region (the feasible set is convex and
    // contains the start, so a shortened solution stays feasible).
    d = solve_once(m, p, s, g0, req, trace);
    const double scale = bound_scale(d, req);
    reached = scale >= 1.0;
    if (pass == 0 && wanted != nullptr) *wanted = {d.head<3>().norm(), d.tail<3>().norm()};

    // Stage 5, once the motion ends in this sub-step: the friction cone decides, the anchors move
    // between two solves, and the rows are solved again.
    if (reached && !friction_checked) {
      friction_checked = true;
      if (slip_anchors(p, s, g0, req.G, trace)) {
        d = solve_once(m, p, s, g0, req, trace);
        d *= bound_scale(d, req);
      }
    } else {
      d *= scale;
    }

    // Re-check at the solution.
    const Pose g1 = apply_displacement(g0, d);
    const Recheck check = recheck_rigid(m, s.constants, s.collision, g1, req.mask, s.pairs);
    if (check.worst >= -tol) return g1;
    if (check.added == 0) break;
  }

  // Overlap remains: shorten the step to the largest clear fraction.
  trace.flags |= kFlagBacktracked;
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 10; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (rigid_clearance(m, s.constants, s.collision, apply_displacement(g0, d * mid), req.mask) >= -tol)
      lo = mid;
    else
      hi = mid;
  }
  return apply_displacement(g0, d * lo);
}

}  // namespace cariesim::detail
