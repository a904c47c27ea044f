// Stage 4, solve: the QP of the rows (solver/qp.hpp) and what its answer means for the step. Every
// status other than Optimal raises a flag: Infeasible and BadInput (and a non-finite answer) leave
// the tool where it is; ActiveSetFull and IterationLimit keep the solver's last dual iterate, which
// is finite and honours the rows it had made active, and say so.
#include "render/solve.hpp"

#include <algorithm>

namespace cariesim::detail {

uint32_t flags_of(QpStatus status) {
  switch (status) {
    case QpStatus::Optimal:
      return 0u;
    case QpStatus::Infeasible:
    case QpStatus::BadInput:
      return kFlagInfeasible;
    case QpStatus::ActiveSetFull:
      return kFlagQpActiveSetFull;
    case QpStatus::IterationLimit:
      return kFlagQpIterationLimit;
  }
  return kFlagInfeasible;
}

void solve_rows(const RowSet& rows, const RegionSet& regions, QpSolver& solver, Solution& out) {
  // The QP; an answer that cannot be used (infeasible, bad input, not finite) moves nothing and
  // carries no force.
  const QpStatus status = solver.solve(rows.problem, out.qp);
  out.flags = flags_of(status);
  out.d = out.qp.x;
  if (status == QpStatus::Infeasible || status == QpStatus::BadInput || !out.d.allFinite()) {
    out.flags |= kFlagInfeasible;
    out.d.setZero();
    out.qp.lambda.fill(0.0);
  }

  // Each region's normal force: the sum of its contact rows' multipliers.
  for (int r = 0; r < regions.count; ++r) out.region_force[r] = 0.0;
  for (int row = 0; row < rows.problem.row_count; ++row) {
    const RowMeta& meta = rows.meta[row];
    if (meta.kind == RowKind::Contact && meta.region >= 0)
      out.region_force[meta.region] += std::max(0.0, out.qp.lambda[row]);
  }
}

void remember_loaded_pairs(const PairSet& pairs, const RegionSet& regions, const RowSet& rows,
                           const Solution& solution, bool in_tunnel,
                           std::span<const ContactSet::Capped> capped, CarriedPairs& out) {
  out.count = 0;
  if (in_tunnel) return;
  const auto was_capped = [&](const PairRef& ref) {
    return std::any_of(capped.begin(), capped.end(), [&](const ContactSet::Capped& c) {
      return c.tool_leaf == ref.tool_leaf && c.object == ref.object;
    });
  };
  for (int row = 0; row < rows.problem.row_count && out.count < kMaxCarried; ++row) {
    const RowMeta& meta = rows.meta[row];
    if (meta.kind != RowKind::Contact || meta.region < 0 || !(solution.qp.lambda[row] > 0.0)) continue;
    PairRef ref = pairs.refs[meta.pair];
    if (!regions.regions[meta.region].compliant && !was_capped(ref)) continue;
    ref.forced = ref.carried = false;
    out.refs[out.count++] = ref;
  }
}

}  // namespace cariesim::detail
