#include "training/stats.hpp"

#include <boost/math/distributions/fisher_f.hpp>
#include <cmath>
#include <limits>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim::training {

namespace {

void require_finite(const std::vector<double>& values, const char* what) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i]))
      throw Error(std::string(what) + ": value " + std::to_string(i) + " is not a finite number");
}

double mean_of(const std::vector<double>& values) {
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum / static_cast<double>(values.size());
}

// Sum of (x - centre)^2: the second pass of the two-pass variance, exact for shifted data.
double squares_about(const std::vector<double>& values, double centre) {
  double sum = 0.0;
  for (double v : values) sum += (v - centre) * (v - centre);
  return sum;
}

}  // namespace

Summary summarize(const std::vector<double>& values) {
  require_finite(values, "summary");
  Summary s;
  s.n = values.size();
  if (s.n == 0) return s;
  s.mean = mean_of(values);
  if (s.n >= 2) s.sd = std::sqrt(squares_about(values, *s.mean) / static_cast<double>(s.n - 1));
  return s;
}

std::optional<double> least_squares_slope(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size())
    throw Error("slope: " + std::to_string(x.size()) + " x values against " + std::to_string(y.size()) +
                " y values");
  require_finite(x, "slope");
  require_finite(y, "slope");
  if (x.size() < 2) return std::nullopt;
  const double mx = mean_of(x), my = mean_of(y);
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
  }
  if (sxx == 0.0) return std::nullopt;
  return sxy / sxx;
}

double f_distribution_upper_tail(double f, double df1, double df2) {
  if (!std::isfinite(f) || f < 0.0)
    throw Error("F distribution: F = " + std::to_string(f) + " is not a finite F >= 0");
  if (!std::isfinite(df1) || !std::isfinite(df2) || df1 <= 0.0 || df2 <= 0.0)
    throw Error("F distribution: degrees of freedom (" + std::to_string(df1) + ", " + std::to_string(df2) +
                ") are not both positive");
  const boost::math::fisher_f_distribution<double> dist(df1, df2);
  return boost::math::cdf(boost::math::complement(dist, f));
}

Anova one_way_anova(const std::vector<std::vector<double>>& groups) {
  Anova a;
  // Group means and the grand mean over the groups that hold values.
  std::vector<double> all;
  a.group_means.reserve(groups.size());
  for (const std::vector<double>& g : groups) {
    require_finite(g, "ANOVA");
    a.group_means.push_back(g.empty() ? 0.0 : mean_of(g));
    if (!g.empty()) ++a.groups;
    all.insert(all.end(), g.begin(), g.end());
  }
  a.n = all.size();
  if (a.n > 0) a.grand_mean = mean_of(all);

  // Sums of squares between and within the groups.
  for (std::size_t i = 0; i < groups.size(); ++i) {
    if (groups[i].empty()) continue;
    const double d = a.group_means[i] - a.grand_mean;
    a.ss_between += static_cast<double>(groups[i].size()) * d * d;
    a.ss_within += squares_about(groups[i], a.group_means[i]);
  }
  a.df1 = a.groups >= 2 ? static_cast<int>(a.groups) - 1 : 0;
  a.df2 = a.n > a.groups ? static_cast<int>(a.n - a.groups) : 0;

  // F and p, unless one of them does not exist.
  if (a.groups < 2) {
    a.note = a.groups == 0 ? "no values" : "one group only: F needs two groups with values";
    return a;
  }
  if (a.df2 == 0) {
    a.note = "no within-group degrees of freedom: every group holds one value";
    return a;
  }
  // Zero within-group variance, up to rounding at the data's scale (F would be infinite or 0/0).
  double scale = 0.0;
  for (double v : all) scale += v * v;
  if (a.ss_within <= 64.0 * std::numeric_limits<double>::epsilon() * scale) {
    a.note = "zero variance within groups: F is undefined";
    return a;
  }
  a.f = (a.ss_between / a.df1) / (a.ss_within / a.df2);
  a.p = f_distribution_upper_tail(*a.f, a.df1, a.df2);
  return a;
}

}  // namespace cariesim::training
