#pragma once
/// A small dense QP, the optimisation of the configuration-based method (paper eq. 1, docs/design.md §4):
///
///   minimise   1/2 (x - x_t)^T G (x - x_t)          x in R^6, G symmetric positive definite
///   subject to a_i^T x + c_i lambda_i >= b_i        inequality rows (c_i >= 0: compliance, mm/N)
///              a_j^T x + c_j lambda_j  = b_j        equality rows
///
/// A row with c_i > 0 is a compliant (regularised) constraint: it may be violated by c_i * lambda_i,
/// where lambda_i >= 0 is its multiplier. With rows in mm and G in N/mm (N·mm/rad for rotations) the
/// multipliers are the contact forces in N. Compliant tissue of stiffness k gives c = 1/k.
///
/// Method: Goldfarb-Idnani dual active set, written on the dual LCP
///   w = (A G^-1 A^T + C) lambda + (A x_t - b) >= 0, lambda >= 0, lambda^T w = 0,
/// starting from the unconstrained minimum (or a warm active set), adding the most violated row,
/// taking partial steps that drop rows whose multipliers would turn negative, and declaring the
/// problem infeasible when a violated row is linearly dependent on the active ones with no row to
/// drop. Fixed capacity, no allocation.
///
/// Stages of `solve`, in the metric of G = L L^T (u_i = L^-1 a_i, y = L^T (x - x_t), so the
/// objective is 1/2 |y|^2 and M = A G^-1 A^T + C has entries u_i^T u_j + c_i delta_ij):
///  1. Check the input (finite, bounded, G SPD, row count); bad input returns x_t, BadInput.
///  2. Transform the rows into the metric, once: u_i, beta_i = b_i - a_i^T x_t, M_ii.
///  3. Equality rows enter first (never dropped; a consistent dependent one is skipped).
///  4. Warm start: rows whose keys were active last time are appended to the active set S unless
///     they are dependent (Schur complement ~ 0); lambda_S solves M_SS lambda_S = beta_S and the
///     inequality row with the most negative multiplier is dropped until all are >= 0.
///  5. Dual loop: pick the most violated row p (violation scaled by sqrt(M_pp)); the step
///     lambda_S -= t r, lambda_p += t with M_SS r = M_Sp keeps the active rows tight and raises w_p
///     at rate s = M_pp - M_Sp^T r (the Schur complement). The full step t = -w_p / s adds p; a
///     partial step stops where an active inequality multiplier reaches zero and drops that row.
///     s ~ 0 with nothing to drop: infeasible. M_SS is kept as a Cholesky factor, appended on
///     additions and refactored from the removed position on drops. For a dependent row the rates
///     r are recomputed by a QR least squares on [U_S; sqrt(C_S)] (the normal equations square the
///     condition number, and roundoff must not invent a row to drop).
///  6. At the first optimum, refine lambda_S from M_SS lambda_S = beta_S (dropping any inequality
///     whose refined multiplier is negative) and scan once more; map back: x = x_t + L^-T y.

#include <array>
#include <cstdint>

#include "cariesim/common/math.hpp"

namespace cariesim {

inline constexpr int kQpMaxRows = 96;    ///< rows per problem
inline constexpr int kQpMaxActive = 24;  ///< simultaneously active rows
inline constexpr int kQpMaxIterations = 8 * kQpMaxRows;  ///< dual steps per solve before IterationLimit
/// Largest magnitude accepted for any entry of G, x_target, a, b and compliance (and the smallest
/// accepted pivot of G is its inverse); beyond it the input is reported as BadInput.
inline constexpr double kQpMaxMagnitude = 1e9;

/// One constraint row a^T x + compliance * lambda >= b (or = b).
struct QpRow {
  Vec6 a = Vec6::Zero();    ///< row of the m x 6 constraint Jacobian (translation mm/mm, rotation mm/rad)
  double b = 0.0;           ///< mm
  double compliance = 0.0;  ///< mm/N, 0 = rigid
  bool equality = false;    ///< true: a^T x + c lambda = b, lambda of either sign
  uint64_t key = 0;         ///< identity across solves, for warm starts (0 = none)
};

/// The problem: weight, target and up to kQpMaxRows rows.
struct QpProblem {
  Mat6 G = Mat6::Identity();           ///< 6 x 6 weight (N/mm, N·mm/rad), symmetric positive definite
  Vec6 x_target = Vec6::Zero();        ///< the unconstrained minimiser x_t (mm, rad)
  std::array<QpRow, kQpMaxRows> rows;  ///< rows [0, row_count) are used
  int row_count = 0;                   ///< number of rows in use

  /// Appends a row; returns false (and drops it) when the problem is full.
  bool add(const QpRow& row);
};

/// How a solve ended. Every status comes with a finite x.
enum class QpStatus : uint8_t {
  Optimal,         ///< KKT conditions hold to tolerance
  Infeasible,      ///< a violated row depends on the active rigid rows; x is the last dual iterate
  IterationLimit,  ///< the dual loop did not finish; x is the last dual iterate
  ActiveSetFull,   ///< more than kQpMaxActive rows wanted to be active; x is the last dual iterate
  BadInput,        ///< non-finite or out-of-range input, G not SPD; x = x_target made finite
};

/// The answer of a solve.
struct QpResult {
  Vec6 x = Vec6::Zero();                    ///< solution (mm, rad)
  std::array<double, kQpMaxRows> lambda{};  ///< multipliers (N); 0 for inactive rows
  QpStatus status = QpStatus::Optimal;      ///< how the solve ended
  int iterations = 0;                       ///< dual steps: a full step adds a row, a partial step drops one
  int active = 0;                           ///< rows in the final active set
  int seeded = 0;  ///< rows the warm start kept in the active set before the dual loop
};

/// Goldfarb-Idnani dual active-set solver with a remembered active set. Allocation-free.
class QpSolver {
 public:
  /// A solver that stops with IterationLimit after `max_iterations` dual steps (at least 1).
  explicit QpSolver(int max_iterations = kQpMaxIterations);
  /// Solves `problem`; when `warm` is set, starts from the rows whose keys were active last time.
  QpStatus solve(const QpProblem& problem, QpResult& result, bool warm = true);
  /// Forgets the remembered active set.
  void reset();

 private:
  std::array<uint64_t, kQpMaxActive> warm_keys_{};  ///< sorted keys of the last active set
  int warm_count_ = 0;                              ///< keys in use in warm_keys_
  int max_iterations_ = kQpMaxIterations;           ///< dual steps per solve
};

}  // namespace cariesim
