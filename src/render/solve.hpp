#pragma once
// Stage 4, solve (solve.cpp): the QP of the rows (solver/qp.hpp) and what its answer means for the
// step; and which pairs' rows bore load, carried to the next solve (CarriedPairs).

#include <array>
#include <cstdint>
#include <span>

#include "cariesim/collision/collide.hpp"
#include "cariesim/solver/qp.hpp"
#include "render/pairs.hpp"
#include "render/regions.hpp"
#include "render/rows.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

/// The solve stage's output.
struct Solution {
  Vec6 d = Vec6::Zero();  ///< mm, rad: displacement from the rows' configuration (zero when infeasible)
  QpResult qp;            ///< multipliers per row (N; zero when infeasible) and the QP's status
  /// kFlagInfeasible (Infeasible, BadInput or a non-finite answer), kFlagQpActiveSetFull,
  /// kFlagQpIterationLimit.
  uint32_t flags = 0;
  std::array<double, kMaxRegions> region_force{};  ///< N, sum of each region's contact multipliers
};

/// The StepFlag bits a QP status raises (none for Optimal).
uint32_t flags_of(QpStatus status);
/// Solves the rows; maps the status to flags; sums each region's normal force.
void solve_rows(const RowSet& rows, const RegionSet& regions, QpSolver& solver, Solution& out);

/// Remembers the pairs of the contact rows with a positive multiplier that are compliant, or rigid of
/// a (tool leaf, object) in `capped` (at most kMaxCarried; none inside a tunnel, whose rows hold the
/// tool).
void remember_loaded_pairs(const PairSet& pairs, const RegionSet& regions, const RowSet& rows,
                           const Solution& solution, bool in_tunnel,
                           std::span<const ContactSet::Capped> capped, CarriedPairs& out);

}  // namespace cariesim::detail
