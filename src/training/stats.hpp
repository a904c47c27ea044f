#pragma once
// The statistics of `cariesim report` (docs/reports.md): mean and sample standard deviation, and the
// one-way ANOVA the paper runs between caries levels (§4.1.2, §5.2: "F(1, 8) = 14.496, p < 0.05").
// Nothing here returns NaN: a value that does not exist (the mean of nothing, the SD of one value, F
// without within-group variance) is an empty optional, and the ANOVA says why in `note`.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace cariesim::training {

/// Mean and sample standard deviation (n - 1) of a list of finite values.
struct Summary {
  std::size_t n = 0;           ///< how many values
  std::optional<double> mean;  ///< empty when n == 0
  std::optional<double> sd;    ///< sample SD, sqrt(sum (x - mean)^2 / (n - 1)); empty when n < 2
};

/// Summary of `values`; throws cariesim::Error when one is not finite.
Summary summarize(const std::vector<double>& values);

/// One-way analysis of variance between groups of observations.
///   SS_between = sum_g n_g (mean_g - mean)^2, df1 = k - 1
///   SS_within  = sum_g sum_i (x_gi - mean_g)^2, df2 = N - k
///   F = (SS_between / df1) / (SS_within / df2), p = P(F(df1, df2) > F)
/// with k the groups that hold values and N all their values.
struct Anova {
  std::size_t groups = 0;           ///< k: groups with at least one value
  std::size_t n = 0;                ///< N: values in those groups
  std::vector<double> group_means;  ///< mean of each input group (0 for an empty one), in input order
  double grand_mean = 0.0;          ///< mean of all values (0 when there are none)
  double ss_between = 0.0;          ///< sum of squares between groups
  double ss_within = 0.0;           ///< sum of squares within groups
  int df1 = 0;                      ///< k - 1 (0 when k < 2)
  int df2 = 0;                      ///< N - k (0 when N <= k)
  std::optional<double> f;          ///< empty when undefined (see note)
  std::optional<double> p;          ///< upper tail of F(df1, df2) at f; empty with f
  std::string note;                 ///< why f is undefined; "" when it is defined
};

/// One-way ANOVA of `groups` (each a list of finite values; empty groups are left out of k and N);
/// throws cariesim::Error when a value is not finite. F is undefined with fewer than two groups,
/// with no within-group degrees of freedom (every group holds one value) and with zero variance
/// within the groups.
Anova one_way_anova(const std::vector<std::vector<double>>& groups);

/// Least-squares slope of y against x: sum (x - mean x)(y - mean y) / sum (x - mean x)^2. Empty
/// with fewer than two points or when every x is the same; throws cariesim::Error when the lists
/// differ in length or a value is not finite.
std::optional<double> least_squares_slope(const std::vector<double>& x, const std::vector<double>& y);

/// P(X > f) for X ~ F(df1, df2) (Boost.Math's fisher_f_distribution); f >= 0 finite, df1, df2 > 0,
/// else throws cariesim::Error.
double f_distribution_upper_tail(double f, double df1, double df2);

}  // namespace cariesim::training
