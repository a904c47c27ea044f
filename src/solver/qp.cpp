#include "cariesim/solver/qp.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>

namespace cariesim {

namespace {

// A row counts as violated when its scaled violation exceeds this fraction of the magnitudes that
// entered its evaluation (|b|, |a|^T |x_t| and |y|): the roundoff level, with margin.
constexpr double kFeasTol = 1e-10;
// A row is linearly dependent on the active set when its Schur complement s is below this fraction
// of its diagonal M_pp (s is a sum of squares, computed without cancellation).
constexpr double kDependentTol = 1e-12;
// An active multiplier blocks a step only when its scaled rate r_j sqrt(M_jj / M_pp) exceeds this
// fraction of the largest scaled rate (or of 1): smaller rates are roundoff.
constexpr double kBlockTol = 1e-10;
// G is SPD enough when its smallest Cholesky pivot squared exceeds this fraction of the largest.
constexpr double kSpdTol = 1e-13;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Scratch of one solve, on the stack (about 12 KB); nothing is zero-initialised that is not read.
struct Work {
  const QpProblem* pb = nullptr;
  int m = 0;
  Mat6 l_inv;                               // L^-1 with G = L L^T, sqrt(mm/N)
  bool diagonal_g = false;                  // G (hence L^-1) is diagonal
  std::array<Vec6, kQpMaxRows> u;           // u_i = L^-1 a_i, sqrt(mm/N) per unit of a
  std::array<double, kQpMaxRows> beta;      // b_i - a_i^T x_t, mm
  std::array<double, kQpMaxRows> diag;      // M_ii = u_i^T u_i + c_i, mm/N
  std::array<double, kQpMaxRows> inv_norm;  // 1 / sqrt(M_ii), or 1 for a zero rigid row
  std::array<double, kQpMaxRows> tol;       // violation threshold from |b|, |a|^T |x_t|, sqrt(N mm)
  std::array<int8_t, kQpMaxRows> slot;      // position in the active set, -1 if inactive
  std::array<int, kQpMaxActive> rows;       // active rows in order of the factor
  std::array<double, kQpMaxActive> lambda;  // their multipliers, N
  Eigen::Matrix<double, kQpMaxActive, kQpMaxActive> chol;  // lower Cholesky factor of M_SS
  int k = 0;                                               // active rows
  Vec6 y;                        // L^T (x - x_t) = U_S lambda_S (+ entering row), sqrt(N mm)
  int entering = -1;             // row in transit when the loop stopped early
  double entering_lambda = 0.0;  // its multiplier, N
  int iterations = 0;
  int max_iterations = kQpMaxIterations;  // dual steps before IterationLimit
  int seeded = 0;
};

using ActiveVec = std::array<double, kQpMaxActive>;

// Finite and within the accepted magnitude (false for NaN and inf too).
bool bounded(double v) { return std::abs(v) <= kQpMaxMagnitude; }

// x_t with NaN replaced by 0 and everything clamped to the accepted magnitude.
Vec6 finite_target(const Vec6& x_t) {
  Vec6 x;
  for (int i = 0; i < 6; ++i) {
    const double v = x_t[i];
    x[i] = std::isnan(v) ? 0.0 : std::clamp(v, -kQpMaxMagnitude, kQpMaxMagnitude);
  }
  return x;
}

// Input checks of everything but the rows (row count, x_t, G bounded, symmetric, positive definite
// with bounded conditioning), and the factor L^-1 of G = L L^T. A diagonal G (the usual case) is
// recognised and factored directly.
bool factor_weight(const QpProblem& pb, Mat6& l_inv, bool& diagonal) {
  if (pb.row_count < 0 || pb.row_count > kQpMaxRows) return false;
  for (int i = 0; i < 6; ++i) {
    if (!bounded(pb.x_target[i])) return false;
  }
  double g_max = 0.0;
  diagonal = true;
  for (int i = 0; i < 36; ++i) {
    const double g = pb.G.data()[i];
    if (!bounded(g)) return false;
    g_max = std::max(g_max, std::abs(g));
    if (i % 7 != 0 && g != 0.0) diagonal = false;
  }
  for (int i = 0; i < 6 && !diagonal; ++i) {
    for (int j = 0; j < i; ++j) {
      if (std::abs(pb.G(i, j) - pb.G(j, i)) > 1e-9 * g_max) return false;
    }
  }

  // Cholesky pivots L_ii^2 must be bounded away from zero, absolutely and relative to the largest.
  Vec6 pivots;
  Mat6 l;
  if (diagonal) {
    pivots = pb.G.diagonal();
  } else {
    const Eigen::LLT<Mat6> llt(pb.G);
    if (llt.info() != Eigen::Success) return false;
    l = llt.matrixL();
    pivots = l.diagonal().cwiseAbs2();
  }
  const double p_min = pivots.minCoeff();
  if (!(p_min >= 1.0 / kQpMaxMagnitude) || !(p_min >= kSpdTol * pivots.maxCoeff())) return false;

  // L^-1 by substitution, column by column (Eigen sends a matrix right-hand side through its
  // blocked general path, several times slower at 6 x 6).
  l_inv.setZero();
  if (diagonal) {
    l_inv.diagonal() = pivots.cwiseSqrt().cwiseInverse();
    return true;
  }
  for (int j = 0; j < 6; ++j) {
    l_inv(j, j) = 1.0 / l(j, j);
    for (int i = j + 1; i < 6; ++i) {
      double sum = 0.0;
      for (int k = j; k < i; ++k) sum += l(i, k) * l_inv(k, j);
      l_inv(i, j) = -sum / l(i, i);
    }
  }
  return l_inv.allFinite();
}

// Signed violation of row i at the current y with its own multiplier `lambda_i` (mm): negative
// means violated. For the row's own compliance the multiplier is that of the row.
double residual(const Work& w, int i, double lambda_i) {
  return w.u[i].dot(w.y) - w.beta[i] + w.pb->rows[i].compliance * lambda_i;
}

// M_Sp: the coupling of row p with each active row, u_j^T u_p.
void coupling(const Work& w, int p, ActiveVec& out) {
  for (int j = 0; j < w.k; ++j) out[j] = w.u[w.rows[j]].dot(w.u[p]);
}

// Solves L v = rhs in place (forward substitution with the active factor).
void solve_lower(const Work& w, ActiveVec& v) {
  for (int i = 0; i < w.k; ++i) {
    double s = v[i];
    for (int j = 0; j < i; ++j) s -= w.chol(i, j) * v[j];
    v[i] = s / w.chol(i, i);
  }
}

// Solves L^T v = rhs in place (back substitution with the active factor).
void solve_upper(const Work& w, ActiveVec& v) {
  for (int i = w.k - 1; i >= 0; --i) {
    double s = v[i];
    for (int j = i + 1; j < w.k; ++j) s -= w.chol(j, i) * v[j];
    v[i] = s / w.chol(i, i);
  }
}

// y = U_S lambda_S + lambda_extra u_extra: the primal point that matches the multipliers exactly.
void update_y(Work& w, int extra, double lambda_extra) {
  w.y.setZero();
  for (int j = 0; j < w.k; ++j) w.y.noalias() += w.lambda[j] * w.u[w.rows[j]];
  if (extra >= 0) w.y.noalias() += lambda_extra * w.u[extra];
}

// Schur complement of row p given r = M_SS^-1 M_Sp, as the sum of squares
// s = |u_p - U_S r|^2 + c_p + sum_j c_j r_j^2 (equal to M_pp - M_Sp^T r, without the cancellation).
double schur(const Work& w, int p, const ActiveVec& r) {
  Vec6 z = w.u[p];
  double s = w.pb->rows[p].compliance;
  for (int j = 0; j < w.k; ++j) {
    const int row = w.rows[j];
    z.noalias() -= r[j] * w.u[row];
    s += w.pb->rows[row].compliance * r[j] * r[j];
  }
  return s + z.squaredNorm();
}

// For a row p dependent on the active set, the rates r from the normal equations M_SS r = M_Sp carry
// the roundoff of cond(M_SS) = cond(U~)^2, enough to invent a blocking row where there is none. They
// are recomputed as the least-squares solution of U~ r = u~_p with U~ = [U_S; sqrt(C_S)] (whose normal
// equations those are) by a column-pivoted QR, which carries the roundoff of cond(U~) only.
void dependent_rates(const Work& w, int p, ActiveVec& r) {
  constexpr int kMaxAug = 6 + kQpMaxActive;
  const int k = w.k;
  if (k == 0) return;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxAug, kQpMaxActive> aug(6 + k, k);
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxAug, 1> rhs(6 + k);
  aug.setZero();
  rhs.setZero();
  for (int j = 0; j < k; ++j) {
    aug.block<6, 1>(0, j) = w.u[w.rows[j]];
    aug(6 + j, j) = std::sqrt(w.pb->rows[w.rows[j]].compliance);
  }
  rhs.head<6>() = w.u[p];
  const Eigen::ColPivHouseholderQR<decltype(aug)> qr(aug);
  const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kQpMaxActive, 1> sol = qr.solve(rhs);
  for (int j = 0; j < k; ++j) r[j] = sol[j];
}

// Appends row p to the active set: the factor's new row is l = L^-1 M_Sp, its diagonal sqrt(s).
void append_active(Work& w, int p, const ActiveVec& l, double s, double lambda) {
  const int k = w.k;
  for (int j = 0; j < k; ++j) w.chol(k, j) = l[j];
  w.chol(k, k) = std::sqrt(s);
  w.rows[k] = p;
  w.lambda[k] = lambda;
  w.slot[p] = static_cast<int8_t>(k);
  w.k = k + 1;
}

// Removes the active row at position q. Rows before q keep their factor; the rows after it move up
// one place and the trailing block (columns >= q) is refactored from M.
void remove_active(Work& w, int q) {
  w.slot[w.rows[q]] = -1;
  for (int i = q; i + 1 < w.k; ++i) {
    w.rows[i] = w.rows[i + 1];
    w.lambda[i] = w.lambda[i + 1];
    w.slot[w.rows[i]] = static_cast<int8_t>(i);
    for (int j = 0; j < q; ++j) w.chol(i, j) = w.chol(i + 1, j);
  }
  --w.k;
  for (int i = q; i < w.k; ++i) {
    const int ri = w.rows[i];
    for (int j = q; j <= i; ++j) {
      double s = j == i ? w.diag[ri] : w.u[ri].dot(w.u[w.rows[j]]);
      for (int l = 0; l < j; ++l) s -= w.chol(i, l) * w.chol(j, l);
      if (j < i) {
        w.chol(i, j) = s / w.chol(j, j);
      } else {
        // The row was independent when it entered and removals only raise its Schur complement;
        // a non-positive pivot here is roundoff, replaced by the dependency floor.
        w.chol(i, i) = std::sqrt(std::max(s, kDependentTol * w.diag[ri]));
      }
    }
  }
}

// lambda_S = M_SS^-1 beta_S: the multipliers that make every active row tight.
void solve_multipliers(Work& w) {
  ActiveVec v;
  for (int j = 0; j < w.k; ++j) v[j] = w.beta[w.rows[j]];
  solve_lower(w, v);
  solve_upper(w, v);
  for (int j = 0; j < w.k; ++j) w.lambda[j] = v[j];
}

// Makes the active rows tight with non-negative inequality multipliers: solves M_SS lambda = beta_S
// and drops the inequality row with the most negative multiplier until none is left; then y.
void settle_multipliers(Work& w) {
  for (;;) {
    solve_multipliers(w);
    int worst = -1;
    double most_negative = 0.0;
    for (int j = 0; j < w.k; ++j) {
      if (!w.pb->rows[w.rows[j]].equality && w.lambda[j] < most_negative) {
        most_negative = w.lambda[j];
        worst = j;
      }
    }
    if (worst < 0) break;
    remove_active(w, worst);
  }
  update_y(w, -1, 0.0);
}

// Scaled violation threshold of row i at the current point.
double threshold(const Work& w, int i, double y_norm) { return w.tol[i] + kFeasTol * y_norm; }

enum class Enter { Added, Skipped, Infeasible, Full, Limit };

// Brings row p into the active set by dual steps (Goldfarb-Idnani): full step adds it, partial
// steps drop blocking inequality rows first. An equality row is oriented so its violation is <= 0.
Enter enter_row(Work& w, int p) {
  const QpRow& row = w.pb->rows[p];
  const double sigma = (row.equality && residual(w, p, 0.0) > 0.0) ? -1.0 : 1.0;
  double t_p = 0.0;  // oriented multiplier of p accumulated by partial steps
  for (;;) {
    if (w.iterations >= w.max_iterations) {
      w.entering = p;
      w.entering_lambda = sigma * t_p;
      return Enter::Limit;
    }

    // Step direction: r = M_SS^-1 M_Sp (original orientation), l = L^-1 M_Sp for the factor row.
    ActiveVec l;
    coupling(w, p, l);
    solve_lower(w, l);
    ActiveVec r = l;
    solve_upper(w, r);
    const double s = schur(w, p, r);
    const double wp = sigma * residual(w, p, sigma * t_p);  // oriented, <= 0 while p is violated
    const bool dependent = !(s > kDependentTol * w.diag[p]);
    if (dependent) dependent_rates(w, p, r);

    // A dependent row that is already satisfied adds nothing: skip it, folding any multiplier it
    // gathered (only possible through roundoff) back onto the rows it depends on.
    if (dependent && wp * w.inv_norm[p] >= -threshold(w, p, w.y.norm())) {
      if (t_p != 0.0) {
        for (int j = 0; j < w.k; ++j) {
          w.lambda[j] += sigma * t_p * r[j];
          if (!w.pb->rows[w.rows[j]].equality) w.lambda[j] = std::max(w.lambda[j], 0.0);
        }
        update_y(w, -1, 0.0);
      }
      return Enter::Skipped;
    }
    ++w.iterations;

    // Step lengths: full (p becomes tight) and partial (an active inequality multiplier hits 0).
    const double t_full = dependent ? kInf : std::max(-wp, 0.0) / s;
    ActiveVec rate;  // scaled rates sigma r_j sqrt(M_jj / M_pp), dimensionless
    double rate_max = 1.0;
    for (int j = 0; j < w.k; ++j) {
      rate[j] = sigma * r[j] * std::sqrt(w.diag[w.rows[j]]) * w.inv_norm[p];
      rate_max = std::max(rate_max, std::abs(rate[j]));
    }
    double t_drop = kInf;
    int q = -1;
    for (int j = 0; j < w.k; ++j) {
      if (w.pb->rows[w.rows[j]].equality || !(rate[j] > kBlockTol * rate_max)) continue;
      const double t = w.lambda[j] / (sigma * r[j]);
      if (t < t_drop) {
        t_drop = t;
        q = j;
      }
    }
    if (t_full == kInf && q < 0) {
      w.entering = p;
      w.entering_lambda = sigma * t_p;
      return Enter::Infeasible;
    }

    // Full step: p joins the active set (unless the set is at capacity).
    if (t_full <= t_drop) {
      if (w.k == kQpMaxActive) {
        w.entering = p;
        w.entering_lambda = sigma * t_p;
        return Enter::Full;
      }
      for (int j = 0; j < w.k; ++j) w.lambda[j] -= t_full * sigma * r[j];
      t_p += t_full;
      append_active(w, p, l, s, sigma * t_p);
      update_y(w, -1, 0.0);
      return Enter::Added;
    }

    // Partial step: the blocking row's multiplier reaches zero and it leaves the active set.
    for (int j = 0; j < w.k; ++j) w.lambda[j] -= t_drop * sigma * r[j];
    w.lambda[q] = 0.0;
    t_p += t_drop;
    remove_active(w, q);
    update_y(w, p, sigma * t_p);
  }
}

QpStatus status_of(Enter e) {
  switch (e) {
    case Enter::Infeasible:
      return QpStatus::Infeasible;
    case Enter::Full:
      return QpStatus::ActiveSetFull;
    case Enter::Limit:
      return QpStatus::IterationLimit;
    case Enter::Added:
    case Enter::Skipped:
      break;
  }
  return QpStatus::Optimal;
}

}  // namespace

bool QpProblem::add(const QpRow& row) {
  if (row_count < 0 || row_count >= kQpMaxRows) return false;
  rows[row_count++] = row;
  return true;
}

QpSolver::QpSolver(int max_iterations) : max_iterations_(std::max(max_iterations, 1)) {}

void QpSolver::reset() { warm_count_ = 0; }

QpStatus QpSolver::solve(const QpProblem& problem, QpResult& result, bool warm) {
  result.lambda.fill(0.0);
  result.iterations = 0;
  result.active = 0;
  result.seeded = 0;

  // Stage 1: input checks of G and x_t (the rows are checked in stage 2); bad input answers x_t
  // made finite.
  Work w;
  w.pb = &problem;
  w.m = problem.row_count;
  w.max_iterations = max_iterations_;
  bool good = factor_weight(problem, w.l_inv, w.diagonal_g);

  // Stage 2: rows checked (bounded, compliance >= 0) and moved into the metric of G:
  // u_i = L^-1 a_i, beta_i = b_i - a_i^T x_t, M_ii, violation scales.
  const Vec6 x_abs = problem.x_target.cwiseAbs();
  const Vec6 l_diag = w.l_inv.diagonal();
  for (int i = 0; good && i < w.m; ++i) {
    const QpRow& row = problem.rows[i];
    const Vec6 a_abs = row.a.cwiseAbs();
    if (!(a_abs.array() <= kQpMaxMagnitude).all() || !bounded(row.b) || !bounded(row.compliance) ||
        row.compliance < 0.0) {
      good = false;
      break;
    }
    if (w.diagonal_g) {
      w.u[i] = l_diag.cwiseProduct(row.a);
    } else {
      w.u[i].noalias() = w.l_inv * row.a;
    }
    w.beta[i] = row.b - row.a.dot(problem.x_target);
    w.diag[i] = w.u[i].squaredNorm() + row.compliance;
    w.inv_norm[i] = w.diag[i] > 0.0 ? 1.0 / std::sqrt(w.diag[i]) : 1.0;
    w.tol[i] = kFeasTol * (std::abs(row.b) + a_abs.dot(x_abs)) * w.inv_norm[i];
    w.slot[i] = -1;
  }
  if (!good) {
    result.x = finite_target(problem.x_target);
    result.status = QpStatus::BadInput;
    return result.status;
  }
  w.y.setZero();

  // Stage 3: equality rows first; they are never dropped.
  QpStatus status = QpStatus::Optimal;
  for (int i = 0; i < w.m && status == QpStatus::Optimal; ++i) {
    if (problem.rows[i].equality) status = status_of(enter_row(w, i));
  }

  // Stage 4: warm start from the rows whose keys were active last time.
  if (status == QpStatus::Optimal && warm && warm_count_ > 0) {
    const auto keys_begin = warm_keys_.begin();
    const auto keys_end = warm_keys_.begin() + warm_count_;
    const int k_before = w.k;
    for (int i = 0; i < w.m && w.k < kQpMaxActive; ++i) {
      const QpRow& row = problem.rows[i];
      if (row.equality || row.key == 0 || w.slot[i] >= 0) continue;
      if (!std::binary_search(keys_begin, keys_end, row.key)) continue;
      ActiveVec l;
      coupling(w, i, l);
      solve_lower(w, l);
      ActiveVec r = l;
      solve_upper(w, r);
      const double s = schur(w, i, r);
      if (!(s > kDependentTol * w.diag[i])) continue;
      append_active(w, i, l, s, 0.0);
    }
    // Multipliers of the seeded set; drop the most negative inequality until none is left.
    if (w.k > k_before) settle_multipliers(w);
    w.seeded = w.k - k_before;
  }

  // Stage 5: the dual loop; add the most violated row until none is. Stage 6 runs once at the first
  // optimum: the multipliers are refined so every active row is tight, an inequality whose refined
  // multiplier is negative leaves the set, and the scan runs again on the refined point.
  bool refined = false;
  while (status == QpStatus::Optimal) {
    const double y_norm = w.y.norm();
    int p = -1;
    double worst = 0.0;
    for (int i = 0; i < w.m; ++i) {
      if (w.slot[i] >= 0) continue;
      double v = (w.u[i].dot(w.y) - w.beta[i]) * w.inv_norm[i];
      if (problem.rows[i].equality) v = -std::abs(v);
      if (v < -threshold(w, i, y_norm) && v < worst) {
        worst = v;
        p = i;
      }
    }
    if (p < 0) {
      if (refined) break;
      refined = true;
      settle_multipliers(w);
      continue;
    }
    const Enter e = enter_row(w, p);
    if (e == Enter::Skipped) {
      // Only reachable through roundoff; counted so the loop always ends.
      ++w.iterations;
      if (w.iterations >= w.max_iterations) status = QpStatus::IterationLimit;
      continue;
    }
    status = status_of(e);
  }

  // Results: x = x_t + L^-T y and the multipliers per row.
  result.x = problem.x_target + w.l_inv.transpose() * w.y;
  for (int j = 0; j < w.k; ++j) result.lambda[w.rows[j]] = w.lambda[j];
  if (status != QpStatus::Optimal && w.entering >= 0) result.lambda[w.entering] = w.entering_lambda;
  result.iterations = w.iterations;
  result.active = w.k;
  result.seeded = w.seeded;

  // Numerical breakdown guard: a non-finite answer is never returned.
  bool finite = result.x.allFinite();
  for (int i = 0; i < w.m && finite; ++i) finite = std::isfinite(result.lambda[i]);
  if (!finite) {
    result.x = finite_target(problem.x_target);
    result.lambda.fill(0.0);
    result.status = QpStatus::BadInput;
    return result.status;
  }
  result.status = status;

  // Remember the keys of the active inequality rows for the next warm start.
  warm_count_ = 0;
  for (int j = 0; j < w.k; ++j) {
    const QpRow& row = problem.rows[w.rows[j]];
    if (!row.equality && row.key != 0) warm_keys_[warm_count_++] = row.key;
  }
  std::sort(warm_keys_.begin(), warm_keys_.begin() + warm_count_);
  return status;
}

}  // namespace cariesim
