// One bounded optimisation of the graphic tool (paper eq. 1, DESIGN.md §4 steps 1-4):
//   1. collect every sphere pair the tool can reach while moving by at most the sub-step's bound;
//   2. linearise them into rows at g0, add stick rows and the caller's extra rows;
//   3. solve the QP;
//   4. apply the friction cone (final sub-step) and re-solve if an anchor slipped;
//   5. re-check collision at the solution: a new rigid overlap brings its pair in and the sub-step
//      is solved again; if overlaps remain, the step is shortened (bisection) until it is clear.
// The tangent-plane rows are conservative for translations, so step 5 only catches the second-order
// effect of rotations and pairs outside the margin; it rarely runs.
#include <algorithm>
#include <cmath>

#include "render/internal.hpp"

namespace cariesim::detail {

namespace {

// Smallest gap between the tool at g and the rigid objects in mask (0 when nothing overlaps).
double rigid_clearance(const Model& m, StateImpl& s, const Pose& g, ObjectMask mask) {
  s.placed.place(g, 0.0);
  const ClosestPair c = closest(s.placed, m.objects, mask & s.rigid_mask, 0.0);
  return std::isfinite(c.gap) ? std::min(c.gap, 0.0) : 0.0;
}

// Builds the problem at g0 and solves it; returns the displacement (zero when infeasible).
Vec6 solve_rows(const Model& m, const Params& p, StateImpl& s, const Pose& g0, const SubstepRequest& req,
                StepOutput& out) {
  build_regions(m, s, g0);
  s.problem.row_count = 0;
  s.problem.G = req.G;
  s.problem.x_target = req.target;
  out.contacts = add_contact_rows(m, p, s, req.hold_only, out.flags);
  if (req.friction) add_friction_rows(s, g0, out.flags);
  if (req.extra != nullptr) req.extra->add(g0, s.problem, s.meta);
  const QpStatus status = s.solver.solve(s.problem, s.result);
  Vec6 d = s.result.x;
  if (status == QpStatus::Infeasible || status == QpStatus::BadInput || !d.allFinite()) {
    out.flags |= kFlagInfeasible;
    d.setZero();
    s.result.lambda.fill(0.0);
  }
  accumulate_region_forces(s);
  return d;
}

}  // namespace

Pose solve_substep(const Model& m, const Params& p, StateImpl& s, const Pose& g0, const SubstepRequest& req,
                   StepOutput& out, bool& reached) {
  // Step 1: pairs within reach of this sub-step's largest motion.
  set_leaf_margins(m, s, req.trans_bound, req.rot_bound);
  if (!collect_pairs(m, s, g0, req.mask)) out.flags |= kFlagContactOverflow;

  const double tol = m.settings.rigid_tolerance;
  const int max_passes = m.settings.max_rechecks + 2;
  bool friction_checked = !req.friction;
  Vec6 d = Vec6::Zero();
  reached = true;
  for (int pass = 0; pass < max_passes; ++pass) {
    // Steps 2-3: rows and solve, then shorten the motion onto the trust region (the feasible set is
    // convex and contains the start, so a shortened solution stays feasible).
    d = solve_rows(m, p, s, g0, req, out);
    const double trans = d.head<3>().norm(), rot = d.tail<3>().norm();
    const double scale =
        std::min({1.0, trans > 0.0 ? req.trans_bound / trans : 1.0, rot > 0.0 ? req.rot_bound / rot : 1.0});
    reached = scale >= 1.0;

    // Step 4: friction cone, once the motion ends in this sub-step; slipped or released anchors
    // change the rows, so solve once more.
    if (reached && !friction_checked) {
      friction_checked = true;
      int slipped = 0;
      if (slip_anchors(p, s, g0, req.G, slipped) > 0) {
        out.slips += slipped;
        d = solve_rows(m, p, s, g0, req, out);
        const double t2 = d.head<3>().norm(), r2 = d.tail<3>().norm();
        const double s2 =
            std::min({1.0, t2 > 0.0 ? req.trans_bound / t2 : 1.0, r2 > 0.0 ? req.rot_bound / r2 : 1.0});
        d *= s2;
      }
    } else {
      d *= scale;
    }

    // Step 5: re-check at the solution.
    const Pose g1 = apply_displacement(g0, d);
    int added = 0;
    const double worst = recheck_rigid(m, s, g1, req.mask, added);
    if (worst >= -tol) return g1;
    if (added == 0) break;
  }

  // Overlap remains: shorten the step to the largest clear fraction.
  out.flags |= kFlagBacktracked;
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 10; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (rigid_clearance(m, s, apply_displacement(g0, d * mid), req.mask) >= -tol)
      lo = mid;
    else
      hi = mid;
  }
  return apply_displacement(g0, d * lo);
}

}  // namespace cariesim::detail
