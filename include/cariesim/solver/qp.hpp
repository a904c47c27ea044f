#pragma once
/// A small dense QP, the optimisation of the configuration-based method (paper eq. 1, DESIGN.md §4):
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

#include <array>
#include <cstdint>

#include "cariesim/common/math.hpp"

namespace cariesim {

inline constexpr int kQpMaxRows = 96;    ///< rows per problem
inline constexpr int kQpMaxActive = 24;  ///< simultaneously active rows

struct QpRow {
  Vec6 a = Vec6::Zero();   ///< row of the 6 x m constraint Jacobian (translation mm, rotation rad)
  double b = 0.0;          ///< mm
  double compliance = 0.0; ///< mm/N, 0 = rigid
  bool equality = false;
  uint64_t key = 0;        ///< identity across solves, for warm starts (0 = none)
};

struct QpProblem {
  Mat6 G = Mat6::Identity();   ///< 6 x 6 weight (N/mm, N·mm/rad)
  Vec6 x_target = Vec6::Zero();
  std::array<QpRow, kQpMaxRows> rows;
  int row_count = 0;

  /// Appends a row; returns false (and drops it) when the problem is full.
  bool add(const QpRow& row);
};

enum class QpStatus : uint8_t { Optimal, Infeasible, IterationLimit, ActiveSetFull, BadInput };

struct QpResult {
  Vec6 x = Vec6::Zero();
  std::array<double, kQpMaxRows> lambda{};  ///< multipliers (N); 0 for inactive rows
  QpStatus status = QpStatus::Optimal;
  int iterations = 0;
  int active = 0;
};

class QpSolver {
 public:
  /// Solves `problem`; when `warm` is set, starts from the rows whose keys were active last time.
  QpStatus solve(const QpProblem& problem, QpResult& result, bool warm = true);
  /// Forgets the remembered active set.
  void reset();

 private:
  std::array<uint64_t, kQpMaxActive> warm_keys_{};
  int warm_count_ = 0;
};

}  // namespace cariesim
