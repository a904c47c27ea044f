#include "cariesim/solver/qp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <vector>

#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using Rng = std::mt19937_64;
using MatX = Eigen::MatrixXd;
using VecX = Eigen::VectorXd;

double uniform(Rng& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }
bool chance(Rng& rng, double p) { return uniform(rng, 0.0, 1.0) < p; }

Vec3 random_unit(Rng& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 v(n(rng), n(rng), n(rng));
  return v.normalized();
}

// A contact-like row: unit normal n and the moment (p x n) of a lever arm p of 0-30 mm.
Vec6 contact_row(Rng& rng) {
  const Vec3 n = random_unit(rng);
  const Vec3 p = random_unit(rng) * uniform(rng, 0.0, 30.0);
  Vec6 a;
  a << n, p.cross(n);
  return a;
}

Vec6 gaussian_row(Rng& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 a;
  for (int i = 0; i < 6; ++i) a[i] = n(rng);
  return a;
}

// A random SPD weight: diagonal N/mm and N·mm/rad, or a full matrix with eigenvalues 0.5..1000.
Mat6 random_g(Rng& rng, bool full) {
  if (!full) {
    Vec6 d;
    for (int i = 0; i < 3; ++i) d[i] = uniform(rng, 0.2, 5.0);
    for (int i = 3; i < 6; ++i) d[i] = uniform(rng, 50.0, 1000.0);
    return d.asDiagonal();
  }
  std::normal_distribution<double> n(0.0, 1.0);
  Mat6 r;
  for (int i = 0; i < 36; ++i) r.data()[i] = n(rng);
  const Mat6 q = Eigen::HouseholderQR<Mat6>(r).householderQ();
  Vec6 e;
  for (int i = 0; i < 6; ++i) e[i] = std::exp(uniform(rng, std::log(0.5), std::log(1000.0)));
  Mat6 g = q * e.asDiagonal() * q.transpose();
  return 0.5 * (g + g.transpose());
}

// Signed slack of row i at (x, lambda_i): a^T x + c lambda - b.
double slack(const QpRow& row, const Vec6& x, double lambda) {
  return row.a.dot(x) + row.compliance * lambda - row.b;
}

// Magnitude scale of row i's evaluation at x, for relative tolerances.
double row_scale(const QpRow& row, const Vec6& x, double lambda) {
  return 1.0 + std::abs(row.b) + row.a.cwiseAbs().dot(x.cwiseAbs()) + std::abs(row.compliance * lambda);
}

// KKT conditions of the result: stationarity G (x - x_t) = A^T lambda, primal feasibility, sign
// of inequality multipliers, complementarity; all relative to the magnitudes involved.
void expect_kkt(const QpProblem& pb, const QpResult& r, double tol) {
  Vec6 force = Vec6::Zero();
  Vec6 force_abs = Vec6::Zero();
  for (int i = 0; i < pb.row_count; ++i) {
    force += pb.rows[i].a * r.lambda[i];
    force_abs += pb.rows[i].a.cwiseAbs() * std::abs(r.lambda[i]);
  }
  const Vec6 g_dx = pb.G * (r.x - pb.x_target);
  const double stat_scale =
      1.0 + force_abs.maxCoeff() + (pb.G.cwiseAbs() * (r.x - pb.x_target).cwiseAbs()).maxCoeff();
  EXPECT_LE((g_dx - force).cwiseAbs().maxCoeff(), tol * stat_scale) << "stationarity";
  for (int i = 0; i < pb.row_count; ++i) {
    const QpRow& row = pb.rows[i];
    const double s = slack(row, r.x, r.lambda[i]);
    const double scale = row_scale(row, r.x, r.lambda[i]);
    if (row.equality) {
      EXPECT_LE(std::abs(s), tol * scale) << "equality row " << i;
    } else {
      EXPECT_GE(s, -tol * scale) << "row " << i << " violated";
      EXPECT_GE(r.lambda[i], 0.0) << "row " << i << " negative multiplier";
      EXPECT_LE(std::abs(r.lambda[i]) * std::max(s, 0.0), tol * scale * (1.0 + std::abs(r.lambda[i])))
          << "row " << i << " complementarity";
    }
  }
}

struct Reference {
  bool feasible = false;
  Vec6 x = Vec6::Zero();
  std::vector<double> lambda;
};

// Brute force: every subset of the inequality rows (equalities always in) as the active set; the
// KKT system [G -A_S^T; A_S C_S] [x; lambda] = [G x_t; b_S] solved for each; the first subset whose
// solution is primal feasible and has lambda >= 0 on its inequalities is the optimum.
Reference brute_force(const QpProblem& pb) {
  const int m = pb.row_count;
  std::vector<int> eq, ineq;
  for (int i = 0; i < m; ++i) (pb.rows[i].equality ? eq : ineq).push_back(i);
  const int n_ineq = static_cast<int>(ineq.size());
  Reference ref;
  for (long mask = 0; mask < (1L << n_ineq); ++mask) {
    std::vector<int> set = eq;
    for (int j = 0; j < n_ineq; ++j) {
      if (mask & (1L << j)) set.push_back(ineq[j]);
    }
    const int k = static_cast<int>(set.size());
    if (k > kQpMaxActive) continue;
    MatX kkt = MatX::Zero(6 + k, 6 + k);
    VecX rhs = VecX::Zero(6 + k);
    kkt.topLeftCorner<6, 6>() = pb.G;
    rhs.head<6>() = pb.G * pb.x_target;
    for (int j = 0; j < k; ++j) {
      const QpRow& row = pb.rows[set[j]];
      kkt.block<6, 1>(0, 6 + j) = -row.a;
      kkt.block<1, 6>(6 + j, 0) = row.a.transpose();
      kkt(6 + j, 6 + j) = row.compliance;
      rhs[6 + j] = row.b;
    }
    Eigen::FullPivLU<MatX> lu(kkt);
    lu.setThreshold(1e-11);
    if (!lu.isInvertible()) continue;
    const VecX sol = lu.solve(rhs);
    const Vec6 x = sol.head<6>();
    std::vector<double> lambda(m, 0.0);
    bool ok = true;
    for (int j = 0; j < k; ++j) {
      lambda[set[j]] = sol[6 + j];
      if (!pb.rows[set[j]].equality && sol[6 + j] < -1e-9 * (1.0 + sol.tail(k).cwiseAbs().maxCoeff()))
        ok = false;
    }
    for (int i = 0; ok && i < m; ++i) {
      if (slack(pb.rows[i], x, lambda[i]) < -1e-9 * row_scale(pb.rows[i], x, lambda[i])) ok = false;
    }
    if (!ok) continue;
    ref.feasible = true;
    ref.x = x;
    ref.lambda = lambda;
    return ref;
  }
  return ref;
}

// True when the multipliers at the reference optimum are unique: the rigid rows tight there are
// linearly independent (compliant rows' multipliers follow from their own slack).
bool multipliers_unique(const QpProblem& pb, const Reference& ref) {
  std::vector<Vec6> tight;
  for (int i = 0; i < pb.row_count; ++i) {
    const QpRow& row = pb.rows[i];
    if (row.compliance > 0.0) continue;
    if (row.equality || std::abs(slack(row, ref.x, 0.0)) <= 1e-7 * row_scale(row, ref.x, 0.0))
      tight.push_back(row.a);
  }
  if (tight.empty()) return true;
  if (tight.size() > 6) return false;
  MatX a(6, static_cast<int>(tight.size()));
  for (int j = 0; j < static_cast<int>(tight.size()); ++j) a.col(j) = tight[j];
  Eigen::JacobiSVD<MatX> svd(a);
  const VecX sv = svd.singularValues();
  return sv[sv.size() - 1] > 1e-6 * sv[0];
}

struct Mix {
  double compliant = 0.25;  // fraction of compliant rows
  double equality = 0.1;    // fraction of equality rows (at most 3)
  bool full_g = false;
  bool contact_rows = true;
  double push = 3.0;  // scale of x_t - x_f; small: x_t near/inside the feasible set
};

// A random problem that is feasible by construction: rigid rows hold at x_f with slack >= 0 (a third
// of them tight), rigid equality rows pass through x_f; x_t = x_f + a random offset of size `push`.
QpProblem random_problem(Rng& rng, int m, const Mix& mix) {
  QpProblem pb;
  pb.G = random_g(rng, mix.full_g);
  Vec6 x_f;
  for (int i = 0; i < 6; ++i) x_f[i] = uniform(rng, -1.0, 1.0);
  int equalities = 0;
  for (int i = 0; i < m; ++i) {
    QpRow row;
    row.a = mix.contact_rows ? contact_row(rng) : gaussian_row(rng);
    row.key = static_cast<uint64_t>(i + 1);
    if (chance(rng, mix.compliant)) row.compliance = uniform(rng, 0.05, 2.0);
    if (equalities < 3 && chance(rng, mix.equality)) {
      row.equality = true;
      ++equalities;
    }
    const double gap = row.equality || chance(rng, 0.33) ? 0.0 : uniform(rng, 0.0, 1.0);
    row.b = row.a.dot(x_f) - gap + (row.compliance > 0.0 ? uniform(rng, -0.5, 0.5) : 0.0);
    pb.add(row);
  }
  Vec6 offset;
  for (int i = 0; i < 6; ++i) offset[i] = uniform(rng, -1.0, 1.0) * (i < 3 ? mix.push : 0.1 * mix.push);
  pb.x_target = x_f + offset;
  return pb;
}

double inf_norm(const Vec6& v) { return v.cwiseAbs().maxCoeff(); }

TEST(QpClosedForm, RigidRowProjectsOntoThePlane) {
  // A sphere pressed 0.4 mm into a rigid plane z >= 0 with coupling stiffness 2 N/mm: the graphic
  // tool sits on the plane and the force is stiffness x depth along the normal.
  QpProblem pb;
  pb.G = (Vec6() << 2.0, 2.0, 2.0, 300.0, 300.0, 300.0).finished().asDiagonal();
  pb.x_target << 0.3, -0.2, -0.4, 0.01, 0.02, -0.01;
  QpRow row;
  row.a << 0, 0, 1, 0, 0, 0;
  pb.add(row);
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  Vec6 expected = pb.x_target;
  expected[2] = 0.0;
  EXPECT_LE(inf_norm(r.x - expected), 1e-12);
  EXPECT_NEAR(r.lambda[0], 2.0 * 0.4, 1e-12);
  EXPECT_EQ(r.active, 1);
}

TEST(QpClosedForm, OneRowWithLeverArmInAFullMetric) {
  // One rigid row in a full metric: x = x_t + G^-1 a lambda, lambda = (b - a^T x_t) / (a^T G^-1 a).
  Rng rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    QpProblem pb;
    pb.G = random_g(rng, true);
    QpRow row;
    row.a = contact_row(rng);
    row.b = uniform(rng, 0.1, 2.0);
    pb.x_target = Vec6::Zero();
    pb.add(row);
    QpSolver solver;
    QpResult r;
    ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
    const Vec6 g_inv_a = pb.G.llt().solve(row.a);
    const double lambda = row.b / row.a.dot(g_inv_a);
    EXPECT_NEAR(r.lambda[0], lambda, 1e-9 * lambda);
    EXPECT_LE(inf_norm(r.x - lambda * g_inv_a), 1e-9 * (1.0 + inf_norm(lambda * g_inv_a)));
  }
}

TEST(QpClosedForm, CompliantRowIsASeriesSpring) {
  // Tissue of stiffness k (c = 1/k) under a coupling of stiffness k_G, penetration d: the spring
  // pair in series carries F = k_G k / (k_G + k) d, and the tool sinks by F / k into the tissue.
  // From the KKT system: k_G (z - z_t) = F, z + F / k = 0 with z_t = -d.
  const double k_g = 1.5, k = 0.5, d = 0.8;
  QpProblem pb;
  pb.G = (Vec6() << k_g, k_g, k_g, 100.0, 100.0, 100.0).finished().asDiagonal();
  pb.x_target << 0.1, 0.0, -d, 0.0, 0.0, 0.0;
  QpRow row;
  row.a << 0, 0, 1, 0, 0, 0;
  row.compliance = 1.0 / k;
  pb.add(row);
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  const double force = k_g * k / (k_g + k) * d;
  EXPECT_NEAR(r.lambda[0], force, 1e-12);
  EXPECT_NEAR(r.x[2], -force / k, 1e-12);
  EXPECT_NEAR(r.x[0], 0.1, 1e-15);
}

TEST(QpClosedForm, EqualityRowHoldsFromBothSides) {
  // x_0 = 1 with x_t on either side: the multiplier changes sign, the row holds exactly.
  for (const double start : {-2.0, 3.0}) {
    QpProblem pb;
    pb.G = Vec6::Constant(2.0).asDiagonal();
    pb.x_target << start, 0.5, 0.0, 0.0, 0.0, 0.0;
    QpRow row;
    row.a << 1, 0, 0, 0, 0, 0;
    row.b = 1.0;
    row.equality = true;
    pb.add(row);
    QpSolver solver;
    QpResult r;
    ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
    EXPECT_NEAR(r.x[0], 1.0, 1e-14);
    EXPECT_NEAR(r.x[1], 0.5, 1e-15);
    EXPECT_NEAR(r.lambda[0], 2.0 * (1.0 - start), 1e-12);
  }
}

TEST(QpClosedForm, InactiveRowLeavesTheTarget) {
  QpProblem pb;
  pb.x_target << 0.1, 0.2, 0.5, 0.0, 0.01, 0.0;
  QpRow row;
  row.a << 0, 0, 1, 0, 0, 0;
  row.b = 0.2;
  pb.add(row);
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_EQ(r.x, pb.x_target);
  EXPECT_EQ(r.lambda[0], 0.0);
  EXPECT_EQ(r.active, 0);
}

// Compares the solver with the brute-force enumeration on random feasible problems.
void check_against_brute_force(uint64_t seed, int count, const Mix& mix, int max_rows) {
  Rng rng(seed);
  int compared_lambda = 0;
  int with_active = 0;
  QpSolver solver;
  for (int trial = 0; trial < count; ++trial) {
    const int m = 1 + static_cast<int>(rng() % static_cast<uint64_t>(max_rows));
    const QpProblem pb = random_problem(rng, m, mix);
    const Reference ref = brute_force(pb);
    ASSERT_TRUE(ref.feasible) << "seed " << seed << " trial " << trial;
    QpResult r;
    ASSERT_EQ(solver.solve(pb, r, false), QpStatus::Optimal) << "trial " << trial;
    const double scale = std::max({1.0, inf_norm(ref.x), inf_norm(pb.x_target - ref.x)});
    EXPECT_LE(inf_norm(r.x - ref.x), 1e-8 * scale) << "trial " << trial << " m " << m;
    if (r.active > 0) ++with_active;
    if (multipliers_unique(pb, ref)) {
      ++compared_lambda;
      double l_scale = 1.0;
      for (int i = 0; i < m; ++i) l_scale = std::max(l_scale, std::abs(ref.lambda[i]));
      for (int i = 0; i < m; ++i) {
        EXPECT_NEAR(r.lambda[i], ref.lambda[i], 1e-8 * l_scale) << "trial " << trial << " row " << i;
      }
    }
  }
  // The sample must exercise constraints and multipliers, or the comparison proves nothing.
  EXPECT_GT(with_active, count / 2);
  EXPECT_GT(compared_lambda, count / 2);
}

TEST(QpBruteForce, ContactRowsDiagonalMetric) { check_against_brute_force(1, 400, Mix{}, 12); }

TEST(QpBruteForce, ContactRowsFullMetric) {
  Mix mix;
  mix.full_g = true;
  check_against_brute_force(2, 400, mix, 12);
}

TEST(QpBruteForce, GaussianRowsManyEqualities) {
  Mix mix;
  mix.contact_rows = false;
  mix.equality = 0.3;
  mix.full_g = true;
  check_against_brute_force(3, 300, mix, 10);
}

TEST(QpBruteForce, AllRigidFarOutside) {
  Mix mix;
  mix.compliant = 0.0;
  mix.equality = 0.0;
  mix.push = 20.0;
  check_against_brute_force(4, 300, mix, 12);
}

TEST(QpBruteForce, AllCompliant) {
  Mix mix;
  mix.compliant = 1.0;
  mix.equality = 0.0;
  check_against_brute_force(5, 200, mix, 10);
}

TEST(QpBruteForce, TargetNearTheFeasibleSet) {
  // x_t close to x_f: mostly inside, some rows barely violated.
  Mix mix;
  mix.push = 0.05;
  Rng rng(6);
  int inside = 0;
  QpSolver solver;
  for (int trial = 0; trial < 300; ++trial) {
    const QpProblem pb = random_problem(rng, 1 + static_cast<int>(rng() % 12), mix);
    const Reference ref = brute_force(pb);
    ASSERT_TRUE(ref.feasible);
    QpResult r;
    ASSERT_EQ(solver.solve(pb, r, false), QpStatus::Optimal);
    EXPECT_LE(inf_norm(r.x - ref.x), 1e-8 * std::max(1.0, inf_norm(ref.x)));
    if (r.active == 0) {
      ++inside;
      EXPECT_EQ(r.x, pb.x_target);
    }
  }
  EXPECT_GT(inside, 10);
}

TEST(QpDegenerate, DuplicateRows) {
  // The same rigid row five times: one active, the total force that of the single row.
  QpProblem pb;
  pb.G = Vec6::Constant(1.0).asDiagonal();
  pb.x_target << 0.0, 0.0, -1.0, 0.0, 0.0, 0.0;
  QpRow row;
  row.a << 0, 0, 1, 0, 0, 0;
  for (int i = 0; i < 5; ++i) pb.add(row);
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_NEAR(r.x[2], 0.0, 1e-14);
  double total = 0.0;
  for (int i = 0; i < 5; ++i) total += r.lambda[i];
  EXPECT_NEAR(total, 1.0, 1e-12);
  EXPECT_EQ(r.active, 1);
  expect_kkt(pb, r, 1e-12);
}

TEST(QpDegenerate, ParallelRowsTheFurthestWins) {
  // z >= 0, z >= 0.5, z >= 0.2 (same normal, different b), pushed from below: z = 0.5, only the
  // second row carries force, whichever order the solver met them in.
  QpProblem pb;
  pb.G = Vec6::Constant(2.0).asDiagonal();
  pb.x_target << 0.0, 0.0, -1.0, 0.0, 0.0, 0.0;
  for (const double b : {0.0, 0.5, 0.2}) {
    QpRow row;
    row.a << 0, 0, 1, 0, 0, 0;
    row.b = b;
    pb.add(row);
  }
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r, false), QpStatus::Optimal);
  EXPECT_NEAR(r.x[2], 0.5, 1e-14);
  EXPECT_EQ(r.lambda[0], 0.0);
  EXPECT_NEAR(r.lambda[1], 3.0, 1e-12);
  EXPECT_EQ(r.lambda[2], 0.0);
  expect_kkt(pb, r, 1e-12);
}

TEST(QpDegenerate, ParallelRowsWithDifferentScales) {
  // 2z >= 1 and z >= 0.6 (parallel, scaled): z = 0.6.
  QpProblem pb;
  pb.x_target << 0.0, 0.0, -1.0, 0.0, 0.0, 0.0;
  QpRow row;
  row.a << 0, 0, 2, 0, 0, 0;
  row.b = 1.0;
  pb.add(row);
  row.a << 0, 0, 1, 0, 0, 0;
  row.b = 0.6;
  pb.add(row);
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r, false), QpStatus::Optimal);
  EXPECT_NEAR(r.x[2], 0.6, 1e-14);
  expect_kkt(pb, r, 1e-12);
}

TEST(QpDegenerate, ToolWedgedInACornerWithMoreThanSixRigidRows) {
  // Twelve rigid rows through one vertex x_f; x_t pushed into the cone they span: x = x_f and the
  // multipliers (not unique) satisfy KKT.
  Rng rng(21);
  for (int trial = 0; trial < 100; ++trial) {
    QpProblem pb;
    pb.G = random_g(rng, trial % 2 == 1);
    Vec6 x_f;
    for (int i = 0; i < 6; ++i) x_f[i] = uniform(rng, -1.0, 1.0);
    Vec6 push = Vec6::Zero();
    for (int i = 0; i < 12; ++i) {
      QpRow row;
      row.a = contact_row(rng);
      row.b = row.a.dot(x_f);
      row.key = static_cast<uint64_t>(i + 1);
      pb.add(row);
      push += uniform(rng, 0.1, 1.0) * row.a;
    }
    // x_t = x_f - G^-1 A^T mu with mu > 0: x_f is optimal with lambda = mu.
    pb.x_target = x_f - pb.G.llt().solve(push);
    QpSolver solver;
    QpResult r;
    ASSERT_EQ(solver.solve(pb, r, false), QpStatus::Optimal) << trial;
    EXPECT_LE(inf_norm(r.x - x_f), 1e-9 * (1.0 + inf_norm(pb.x_target - x_f))) << trial;
    EXPECT_LE(r.active, 6);
    expect_kkt(pb, r, 1e-9);
  }
}

TEST(QpDegenerate, ZeroRows) {
  QpSolver solver;
  QpResult r;
  // No rows: x = x_t.
  QpProblem pb;
  pb.x_target << 1, 2, 3, 0.1, 0.2, 0.3;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_EQ(r.x, pb.x_target);
  EXPECT_EQ(r.iterations, 0);
  // A zero row 0 >= -1 is always satisfied; 0 >= 1 can never be.
  QpRow row;
  row.b = -1.0;
  pb.add(row);
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_EQ(r.x, pb.x_target);
  pb.rows[0].b = 1.0;
  EXPECT_EQ(solver.solve(pb, r), QpStatus::Infeasible);
  EXPECT_TRUE(r.x.allFinite());
  // A compliant zero row 0 + c lambda >= 1 only loads its spring: lambda = 1 / c, x untouched.
  pb.rows[0].compliance = 0.25;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_EQ(r.x, pb.x_target);
  EXPECT_NEAR(r.lambda[0], 4.0, 1e-12);
}

TEST(QpInfeasible, ContradictoryRigidRows) {
  // a^T x >= 1 and -a^T x >= 1.
  Rng rng(31);
  for (int trial = 0; trial < 50; ++trial) {
    QpProblem pb;
    pb.G = random_g(rng, trial % 2 == 0);
    QpRow row;
    row.a = contact_row(rng);
    row.b = 1.0;
    pb.add(row);
    row.a = -row.a;
    pb.add(row);
    for (int i = 0; i < 4; ++i) {
      QpRow extra;
      extra.a = contact_row(rng);
      extra.b = -1.0;
      pb.add(extra);
    }
    for (int i = 0; i < 6; ++i) pb.x_target[i] = uniform(rng, -2.0, 2.0);
    QpSolver solver;
    QpResult r;
    EXPECT_EQ(solver.solve(pb, r), QpStatus::Infeasible) << trial;
    EXPECT_TRUE(r.x.allFinite());
    for (int i = 0; i < pb.row_count; ++i) EXPECT_TRUE(std::isfinite(r.lambda[i]));
  }
}

TEST(QpInfeasible, VerdictsAgreeWithBruteForce) {
  // Random rows with random b, feasible or not: the solver reports Optimal exactly when the
  // enumeration finds a KKT point (a strictly convex QP has one iff it is feasible), with the same x.
  // Random b also makes near-singular vertices far away (|x| of 1e3-1e4 from data of size 1, forces
  // of 1e9): there both answers carry errors of cond(A) times roundoff, and the trial is not compared.
  Rng rng(33);
  int optimal = 0, infeasible = 0, ill_conditioned = 0;
  QpSolver solver;
  constexpr int kTrials = 600;
  for (int trial = 0; trial < kTrials; ++trial) {
    Mix mix;
    mix.compliant = trial % 3 == 0 ? 0.2 : 0.0;
    mix.equality = 0.1;
    mix.full_g = trial % 2 == 0;
    mix.contact_rows = trial % 4 != 0;
    QpProblem pb = random_problem(rng, 3 + static_cast<int>(rng() % 10), mix);
    for (int i = 0; i < pb.row_count; ++i) pb.rows[i].b = uniform(rng, 0.0, 3.0);
    const Reference ref = brute_force(pb);
    QpResult r;
    const QpStatus s = solver.solve(pb, r, trial % 2 == 0);
    ASSERT_TRUE(r.x.allFinite());
    constexpr double kFar = 100.0;  // mm: a solution this far from data of size 1 is near-singular
    if ((ref.feasible && inf_norm(ref.x) > kFar) || (s == QpStatus::Optimal && inf_norm(r.x) > kFar)) {
      ++ill_conditioned;
      continue;
    }
    ASSERT_EQ(s == QpStatus::Optimal, ref.feasible) << "trial " << trial << " status " << static_cast<int>(s);
    if (ref.feasible) {
      ++optimal;
      EXPECT_LE(inf_norm(r.x - ref.x),
                1e-8 * std::max({1.0, inf_norm(ref.x), inf_norm(pb.x_target - ref.x)}));
    } else {
      ++infeasible;
      EXPECT_EQ(s, QpStatus::Infeasible);
    }
  }
  std::printf("random-b problems: %d optimal, %d infeasible, %d near-singular not compared\n", optimal,
              infeasible, ill_conditioned);
  EXPECT_GT(optimal, 100);
  EXPECT_GT(infeasible, 50);
  EXPECT_LT(ill_conditioned, kTrials / 20);
}

TEST(QpInfeasible, ConflictingEqualities) {
  QpProblem pb;
  QpRow row;
  row.equality = true;
  row.a << 1, 1, 0, 0, 0, 0;
  row.b = 1.0;
  pb.add(row);
  row.a << 2, 2, 0, 0, 0, 0;
  row.b = 3.0;
  pb.add(row);
  QpSolver solver;
  QpResult r;
  EXPECT_EQ(solver.solve(pb, r), QpStatus::Infeasible);
  EXPECT_TRUE(r.x.allFinite());
  // Consistent but redundant equalities are fine.
  pb.rows[1].b = 2.0;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_NEAR(r.x[0] + r.x[1], 1.0, 1e-14);
  expect_kkt(pb, r, 1e-12);
}

TEST(QpInfeasible, WedgeThatComplianceResolves) {
  // The contradictory pair becomes feasible once one side is compliant: the tissue gives way.
  QpProblem pb;
  QpRow row;
  row.a << 1, 0, 0, 0, 0, 0;
  row.b = 1.0;
  pb.add(row);
  row.a = -row.a;
  row.compliance = 0.5;
  pb.add(row);
  QpSolver solver;
  QpResult r;
  ASSERT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_NEAR(r.x[0], 1.0, 1e-14);
  EXPECT_NEAR(r.lambda[1], 4.0, 1e-12);  // -x + 0.5 lambda = 1
  expect_kkt(pb, r, 1e-12);
}

// Sphere-pair rows around a point: object spheres on a shell around the tool tip, tool spheres on
// a shaft; rows n and (p x n) with gaps >= 0 for rigid rows (x = 0 feasible) and a mix of compliant
// rows that may start penetrated.
QpProblem shell_problem(Rng& rng, int m, double compliant_fraction) {
  QpProblem pb;
  pb.G = (Vec6() << 1.0, 1.0, 1.0, 500.0, 500.0, 500.0).finished().asDiagonal();
  for (int i = 0; i < m; ++i) {
    QpRow row;
    const Vec3 n = random_unit(rng);
    const Vec3 p = Vec3(0, 0, uniform(rng, 0.0, 30.0)) + 0.3 * random_unit(rng);
    row.a << n, p.cross(n);
    row.key = static_cast<uint64_t>(1000 + i);
    if (chance(rng, compliant_fraction)) {
      row.compliance = uniform(rng, 0.5, 3.0);
      row.b = -uniform(rng, -0.05, 0.3);
    } else {
      row.b = -uniform(rng, 0.0, 0.3);
    }
    pb.add(row);
  }
  pb.x_target << uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -0.05, 0.05),
      uniform(rng, -0.05, 0.05), uniform(rng, -0.05, 0.05);
  return pb;
}

TEST(QpLarge, KktHoldsWithManyRows) {
  Rng rng(41);
  QpSolver solver;
  int max_active = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int m = trial % 2 == 0 ? 64 : 96;
    const QpProblem pb = shell_problem(rng, m, trial % 3 == 0 ? 0.0 : 0.3);
    QpResult r;
    ASSERT_EQ(solver.solve(pb, r, false), QpStatus::Optimal) << trial;
    expect_kkt(pb, r, 1e-9);
    max_active = std::max(max_active, r.active);
  }
  EXPECT_GE(max_active, 4);
  std::printf("largest active set over the 64-96 row problems: %d\n", max_active);
}

// A tool (six spheres on a shaft) sliding along a bumpy fissure: a floor of object spheres between
// two walls. The QP is linearised at the graphic pose each step, as the haptic step does
// (docs/design.md §4 steps 2-3), and its solution moves the graphic pose. Keys identify sphere pairs.
class SlidingTool {
 public:
  SlidingTool() {
    for (int i = 0; i < 6; ++i) tool_.push_back(Vec3(0.35 * i, 0.0, 0.5 * i));
    for (int ix = -4; ix < 40; ++ix) {
      for (int iy = -3; iy <= 3; ++iy) {
        const double h = 0.12 * std::sin(0.9 * ix) * std::cos(1.3 * iy);
        const double wall = std::abs(iy) == 3 ? 0.9 : 0.0;
        objects_.push_back(Vec3(0.5 * ix, 0.45 * iy, h + wall - 0.9));
      }
    }
    graphic_.setZero();
    graphic_[2] = 0.3;
  }

  // Rows at the current graphic pose for the haptic pose of step `t`: pressed 0.3 mm into the floor,
  // swaying across the fissure into its walls, tilting.
  QpProblem problem(int t) const {
    QpProblem pb;
    pb.G = (Vec6() << 1.0, 1.0, 1.0, 400.0, 400.0, 400.0).finished().asDiagonal();
    Vec6 haptic;
    haptic << 0.01 * t, 1.0 * std::sin(0.02 * t), -0.3, 0.1 * std::sin(0.013 * t), 0.1 * std::cos(0.017 * t),
        0.0;
    pb.x_target = haptic - graphic_;
    const Vec3 origin = graphic_.head<3>();
    const Quat q = quat_from_rotation_vector(graphic_.tail<3>());
    for (int ti = 0; ti < static_cast<int>(tool_.size()); ++ti) {
      const Vec3 lever = q * tool_[ti];
      const Vec3 c = origin + lever;
      for (int oi = 0; oi < static_cast<int>(objects_.size()); ++oi) {
        const Vec3 d = c - objects_[oi];
        const double gap = d.norm() - kToolRadius - kObjectRadius;
        if (gap > 0.5) continue;
        const Vec3 n = d.normalized();
        QpRow row;
        row.a << n, lever.cross(n);
        row.b = -gap;
        row.compliance = objects_[oi].x() > 5.0 && objects_[oi].x() < 9.0 ? 1.5 : 0.0;
        row.key = (static_cast<uint64_t>(ti + 1) << 32) | static_cast<uint64_t>(oi + 1);
        if (!pb.add(row)) return pb;
      }
    }
    return pb;
  }

  void advance(const Vec6& x) { graphic_ += x; }

 private:
  static constexpr double kToolRadius = 0.25;
  static constexpr double kObjectRadius = 0.5;
  std::vector<Vec3> tool_;
  std::vector<Vec3> objects_;
  Vec6 graphic_;
};

TEST(QpWarmStart, SameOptimumAsColdAndFewerIterations) {
  SlidingTool tool;
  QpSolver warm;
  QpSolver cold;
  long warm_iterations = 0, cold_iterations = 0, seeded = 0, rows = 0, active = 0;
  int steps = 0, solved_with_rows = 0;
  for (int t = 0; t < 1200; ++t) {
    const QpProblem pb = tool.problem(t);
    QpResult rw, rc;
    const QpStatus sw = warm.solve(pb, rw, true);
    const QpStatus sc = cold.solve(pb, rc, false);
    ASSERT_EQ(sw, sc) << "step " << t;
    ASSERT_EQ(sw, QpStatus::Optimal) << "step " << t;
    EXPECT_LE(inf_norm(rw.x - rc.x), 1e-9 * (1.0 + inf_norm(rc.x))) << "step " << t;
    expect_kkt(pb, rw, 1e-9);
    warm_iterations += rw.iterations;
    cold_iterations += rc.iterations;
    seeded += rw.seeded;
    rows += pb.row_count;
    active += rc.active;
    if (rc.active > 0) ++solved_with_rows;
    ++steps;
    tool.advance(rw.x);
  }
  std::printf(
      "warm start over %d steps (%.1f rows, %.1f active, %d with contact): %.2f dual steps/solve "
      "warm (+%.2f seeded rows) vs %.2f cold\n",
      steps, static_cast<double>(rows) / steps, static_cast<double>(active) / steps, solved_with_rows,
      static_cast<double>(warm_iterations) / steps, static_cast<double>(seeded) / steps,
      static_cast<double>(cold_iterations) / steps);
  EXPECT_GT(solved_with_rows, steps / 2);
  EXPECT_LE(warm_iterations, cold_iterations);
}

TEST(QpWarmStart, StaleKeysAreDroppedNotTrusted) {
  // Warm keys that now name a row pulling the wrong way (negative multiplier) or a duplicate
  // (dependent) must not change the optimum.
  Rng rng(51);
  QpSolver warm;
  QpSolver cold;
  for (int trial = 0; trial < 300; ++trial) {
    const int m = 2 + static_cast<int>(rng() % 12);
    Mix mix;
    mix.push = trial % 2 == 0 ? 3.0 : 0.2;
    QpProblem pb = random_problem(rng, m, mix);
    // Scramble keys so rows that were active last time map onto unrelated rows now; add a
    // duplicate of the first row with the same key.
    for (int i = 0; i < pb.row_count; ++i) pb.rows[i].key = 1 + (rng() % 6);
    if (!pb.rows[0].equality) pb.add(pb.rows[0]);
    const Reference ref = brute_force(pb);
    ASSERT_TRUE(ref.feasible);
    QpResult rw, rc;
    ASSERT_EQ(warm.solve(pb, rw, true), QpStatus::Optimal) << trial;
    ASSERT_EQ(cold.solve(pb, rc, false), QpStatus::Optimal) << trial;
    const double scale = std::max(1.0, inf_norm(ref.x));
    EXPECT_LE(inf_norm(rw.x - ref.x), 1e-8 * scale) << trial;
    EXPECT_LE(inf_norm(rc.x - ref.x), 1e-8 * scale) << trial;
  }
}

TEST(QpAllocation, SolvesAllocateNothing) {
  // Problems are built before counting; the solves alone run inside the counted window.
  const std::size_t start = test::allocation_count();
  Rng rng(61);
  std::vector<QpProblem> problems;
  for (int i = 0; i < 40; ++i) problems.push_back(shell_problem(rng, 8 + 2 * i, 0.3));
  Mix mix;
  mix.full_g = true;
  for (int i = 0; i < 40; ++i) problems.push_back(random_problem(rng, 12, mix));
  QpProblem bad = problems[0];
  bad.x_target[2] = std::numeric_limits<double>::quiet_NaN();
  problems.push_back(bad);
  QpSolver solver;
  QpResult r;
  int optimal = 0;
  const std::size_t before = test::allocation_count();
  // The counter itself works: building the problem list above allocated.
  EXPECT_GT(before, start);
  for (int round = 0; round < 20; ++round) {
    for (const QpProblem& pb : problems) {
      if (solver.solve(pb, r, round % 2 == 0) == QpStatus::Optimal) ++optimal;
    }
  }
  EXPECT_EQ(test::allocation_count() - before, 0u);
  EXPECT_GT(optimal, 0);
}

TEST(QpRobustness, RandomInputsNeverCrashOrReturnNaN) {
  Rng rng(71);
  const double specials[] = {std::numeric_limits<double>::quiet_NaN(),
                             std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(),
                             1e300,
                             -1e300,
                             0.0,
                             1e-300};
  QpSolver solver;
  int counts[5] = {0, 0, 0, 0, 0};
  for (int trial = 0; trial < 4000; ++trial) {
    const int m = static_cast<int>(rng() % 24);
    Mix mix;
    mix.full_g = chance(rng, 0.5);
    mix.contact_rows = chance(rng, 0.5);
    mix.push = uniform(rng, 0.0, 10.0);
    QpProblem pb = random_problem(rng, m, mix);
    bool corrupted = false;
    const int kind = static_cast<int>(rng() % 8);
    const double special = specials[rng() % 7];
    switch (kind) {
      case 0:  // a special value in x_t
        pb.x_target[rng() % 6] = special;
        corrupted = !std::isfinite(special) || std::abs(special) > kQpMaxMagnitude;
        break;
      case 1:  // in G (kept symmetric)
      {
        const int i = static_cast<int>(rng() % 6), j = static_cast<int>(rng() % 6);
        pb.G(i, j) = pb.G(j, i) = special;
        // Non-finite or huge entries, or a zero/tiny pivot, are bad; a small off-diagonal may be
        // fine (or may make G indefinite, then BadInput is also right).
        corrupted = !std::isfinite(special) || std::abs(special) > kQpMaxMagnitude ||
                    (i == j && special < 1.0 / kQpMaxMagnitude);
        break;
      }
      case 2:  // in a row
        if (m > 0) {
          pb.rows[rng() % static_cast<uint64_t>(m)].a[rng() % 6] = special;
          corrupted = !std::isfinite(special) || std::abs(special) > kQpMaxMagnitude;
        }
        break;
      case 3:  // in b or compliance
        if (m > 0) {
          QpRow& row = pb.rows[rng() % static_cast<uint64_t>(m)];
          (chance(rng, 0.5) ? row.b : row.compliance) = special;
          corrupted = !std::isfinite(special) || std::abs(special) > kQpMaxMagnitude;
        }
        break;
      case 4:  // row count out of range
        pb.row_count = chance(rng, 0.5) ? -1 - static_cast<int>(rng() % 5) : kQpMaxRows + 1;
        corrupted = true;
        break;
      case 5:  // negative compliance or an indefinite G
        if (m > 0 && chance(rng, 0.5)) {
          pb.rows[0].compliance = -0.5;
        } else {
          pb.G(3, 3) = -1.0;
        }
        corrupted = true;
        break;
      default:  // random rows with random b: feasible or not
        for (int i = 0; i < m; ++i) pb.rows[i].b = uniform(rng, -2.0, 2.0);
        break;
    }
    QpResult r;
    const QpStatus s = solver.solve(pb, r, chance(rng, 0.5));
    ASSERT_TRUE(r.x.allFinite()) << trial;
    for (double l : r.lambda) ASSERT_TRUE(std::isfinite(l)) << trial;
    if (corrupted) {
      EXPECT_EQ(s, QpStatus::BadInput) << "trial " << trial << " kind " << kind;
      EXPECT_LE(inf_norm(r.x), kQpMaxMagnitude);
    } else {
      EXPECT_TRUE(s == QpStatus::Optimal || s == QpStatus::Infeasible || s == QpStatus::BadInput) << trial;
    }
    if (s == QpStatus::Optimal) expect_kkt(pb, r, 1e-7);
    ++counts[static_cast<int>(s)];
  }
  std::printf("statuses: optimal %d, infeasible %d, iteration limit %d, full %d, bad input %d\n", counts[0],
              counts[1], counts[2], counts[3], counts[4]);
  EXPECT_GT(counts[0], 1000);
  EXPECT_GT(counts[1], 10);
  EXPECT_GT(counts[4], 1000);
}

TEST(QpBadInput, AnswersTheTargetMadeFinite) {
  QpProblem pb;
  pb.x_target << 1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 0, 0,
      0;
  QpSolver solver;
  QpResult r;
  EXPECT_EQ(solver.solve(pb, r), QpStatus::BadInput);
  EXPECT_EQ(r.x[0], 1.0);
  EXPECT_EQ(r.x[1], 0.0);
  EXPECT_EQ(r.x[2], kQpMaxMagnitude);
  // A non-symmetric G is not accepted either.
  pb.x_target.setZero();
  pb.G(0, 1) = 0.5;
  EXPECT_EQ(solver.solve(pb, r), QpStatus::BadInput);
  EXPECT_EQ(r.x, pb.x_target);
}

TEST(QpProblem, AddStopsAtCapacity) {
  QpProblem pb;
  for (int i = 0; i < kQpMaxRows; ++i) ASSERT_TRUE(pb.add(QpRow{}));
  EXPECT_FALSE(pb.add(QpRow{}));
  EXPECT_EQ(pb.row_count, kQpMaxRows);
}

TEST(QpCapacity, TooManyCompliantRowsReportFull) {
  // Thirty compliant rows all pressed: more than kQpMaxActive want force.
  QpProblem pb;
  pb.x_target << 0, 0, -2.0, 0, 0, 0;
  Rng rng(81);
  for (int i = 0; i < 30; ++i) {
    QpRow row;
    row.a << 0.1 * uniform(rng, -1, 1), 0.1 * uniform(rng, -1, 1), 1, 0, 0, 0;
    row.compliance = 1.0;
    pb.add(row);
  }
  QpSolver solver;
  QpResult r;
  EXPECT_EQ(solver.solve(pb, r), QpStatus::ActiveSetFull);
  EXPECT_TRUE(r.x.allFinite());
  EXPECT_EQ(r.active, kQpMaxActive);
}

TEST(QpCapacity, IterationLimitStopsTheDualLoop) {
  // Two independent violated rows need two dual steps; a solver allowed one stops after it.
  QpProblem pb;
  QpRow x_row, y_row;
  x_row.a << 1, 0, 0, 0, 0, 0;
  x_row.b = 1.0;
  y_row.a << 0, 1, 0, 0, 0, 0;
  y_row.b = 2.0;
  pb.add(x_row);
  pb.add(y_row);
  QpSolver limited(1);
  QpResult r;
  EXPECT_EQ(limited.solve(pb, r), QpStatus::IterationLimit);
  EXPECT_TRUE(r.x.allFinite());
  EXPECT_EQ(r.iterations, 1);
  QpSolver solver;
  EXPECT_EQ(solver.solve(pb, r), QpStatus::Optimal);
  EXPECT_NEAR(r.x[0], 1.0, 1e-12);
  EXPECT_NEAR(r.x[1], 2.0, 1e-12);
  EXPECT_EQ(r.iterations, 2);
}

}  // namespace
}  // namespace cariesim
