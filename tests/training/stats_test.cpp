// The report's statistics against values computed by hand (docs/reports.md, "Formulas").
#include "training/stats.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "cariesim/common/error.hpp"

namespace cariesim::training {
namespace {

// {2, 4, 4, 4, 5, 5, 7, 9}: mean 40 / 8 = 5; squares about the mean 9+1+1+1+0+0+4+16 = 32;
// sample SD sqrt(32 / 7) = 2.1380899... (the population SD would be sqrt(32 / 8) = 2 exactly).
TEST(Stats, SampleStandardDeviationDividesByNMinusOne) {
  const Summary s = summarize({2, 4, 4, 4, 5, 5, 7, 9});
  EXPECT_EQ(s.n, 8U);
  ASSERT_TRUE(s.mean && s.sd);
  EXPECT_DOUBLE_EQ(*s.mean, 5.0);
  EXPECT_DOUBLE_EQ(*s.sd, std::sqrt(32.0 / 7.0));
  EXPECT_NEAR(*s.sd, 2.1380899, 1e-7);
}

// Data shifted by 1e9 keep their SD (the two-pass sum is not the naive sum of squares).
TEST(Stats, StandardDeviationOfShiftedData) {
  const Summary s = summarize({1e9 + 2, 1e9 + 4, 1e9 + 4, 1e9 + 4, 1e9 + 5, 1e9 + 5, 1e9 + 7, 1e9 + 9});
  ASSERT_TRUE(s.sd);
  EXPECT_NEAR(*s.sd, std::sqrt(32.0 / 7.0), 1e-6);
}

TEST(Stats, OneValueHasAMeanAndNoStandardDeviation) {
  const Summary one = summarize({0.4});
  EXPECT_EQ(one.n, 1U);
  ASSERT_TRUE(one.mean);
  EXPECT_DOUBLE_EQ(*one.mean, 0.4);
  EXPECT_FALSE(one.sd);
  const Summary none = summarize({});
  EXPECT_EQ(none.n, 0U);
  EXPECT_FALSE(none.mean);
  EXPECT_FALSE(none.sd);
}

TEST(Stats, NonFiniteValuesAreRefused) {
  EXPECT_THROW(summarize({1.0, std::numeric_limits<double>::quiet_NaN()}), Error);
  EXPECT_THROW(one_way_anova({{1.0, 2.0}, {std::numeric_limits<double>::infinity()}}), Error);
}

// Three groups by hand: A = {1, 2, 3}, B = {4, 5, 6}, C = {6, 8, 10}.
//   group means 2, 5, 8; grand mean 45 / 9 = 5
//   SS_between = 3 (2-5)^2 + 3 (5-5)^2 + 3 (8-5)^2 = 27 + 0 + 27 = 54, df1 = 3 - 1 = 2
//   SS_within = (1+0+1) + (1+0+1) + (4+0+4) = 12, df2 = 9 - 3 = 6
//   F = (54 / 2) / (12 / 6) = 13.5
//   p: for df1 = 2 the F tail has the closed form P(F > f) = (1 + 2 f / df2)^(-df2 / 2)
//      = (1 + 27 / 6)^(-3) = 5.5^-3 = 0.0060105184...; scipy.stats.f.sf(13.5, 2, 6) gives
//      0.006010518407212622 too.
TEST(Stats, AnovaThreeGroupsByHand) {
  const Anova a = one_way_anova({{1, 2, 3}, {4, 5, 6}, {6, 8, 10}});
  EXPECT_EQ(a.groups, 3U);
  EXPECT_EQ(a.n, 9U);
  ASSERT_EQ(a.group_means.size(), 3U);
  EXPECT_DOUBLE_EQ(a.group_means[0], 2.0);
  EXPECT_DOUBLE_EQ(a.group_means[1], 5.0);
  EXPECT_DOUBLE_EQ(a.group_means[2], 8.0);
  EXPECT_DOUBLE_EQ(a.grand_mean, 5.0);
  EXPECT_NEAR(a.ss_between, 54.0, 1e-12);
  EXPECT_NEAR(a.ss_within, 12.0, 1e-12);
  EXPECT_EQ(a.df1, 2);
  EXPECT_EQ(a.df2, 6);
  ASSERT_TRUE(a.f && a.p) << a.note;
  EXPECT_NEAR(*a.f, 13.5, 1e-12);
  EXPECT_NEAR(*a.p, std::pow(5.5, -3.0), 1e-12);
  EXPECT_TRUE(a.note.empty());
}

// Two groups of unequal size: A = {1, 3}, B = {4, 6, 8}.
//   means 2 and 6; grand mean 22 / 5 = 4.4
//   SS_between = 2 (2 - 4.4)^2 + 3 (6 - 4.4)^2 = 11.52 + 7.68 = 19.2, df1 = 1
//   SS_within = (1 + 1) + (4 + 0 + 4) = 10, df2 = 5 - 2 = 3
//   F = 19.2 / (10 / 3) = 5.76
//   p: with df1 = 1, F = t^2 of the pooled two-sample t test, t = 2.4 with 3 df, and the t
//      distribution with 3 df has P(T > t) = 1/2 - (atan(u) + u / (1 + u^2)) / pi, u = t / sqrt(3):
//      u = 1.3856406, atan(u) = 0.9457772, u / (1 + u^2) = 0.4745345, so
//      p = 2 (0.5 - 1.4203117 / pi) = 0.0958745; scipy.stats.f.sf(5.76, 1, 3) = 0.09587448227183103.
TEST(Stats, AnovaUnequalGroupsByHand) {
  const Anova a = one_way_anova({{1, 3}, {4, 6, 8}});
  EXPECT_NEAR(a.grand_mean, 4.4, 1e-12);
  EXPECT_NEAR(a.ss_between, 19.2, 1e-12);
  EXPECT_NEAR(a.ss_within, 10.0, 1e-12);
  EXPECT_EQ(a.df1, 1);
  EXPECT_EQ(a.df2, 3);
  ASSERT_TRUE(a.f && a.p) << a.note;
  EXPECT_NEAR(*a.f, 5.76, 1e-12);
  const double u = 2.4 / std::sqrt(3.0);
  EXPECT_NEAR(*a.p, 2.0 * (0.5 - (std::atan(u) + u / (1.0 + u * u)) / M_PI), 1e-12);
  EXPECT_NEAR(*a.p, 0.09587448227183103, 1e-12);
}

// The paper's Tables 1 and 2: the five dentists' means per level, one observation per dentist, give
// the F(1, 8) the paper prints (§4.1.2: mu_s 14.496, mu_d 11.875; §5.2: k_c 42.124, k_e 3.666).
// For mu_s by hand: mild {0.06, 0.28, 0.19, 0.17, 0.19} mean 0.178, severe {0.21, 0.51, 0.54, 0.65,
// 0.64} mean 0.51, grand mean 0.344; SS_between = 5 (0.166^2 + 0.166^2) = 0.27556;
// SS_within = 0.02468 + 0.1274 = 0.15208; F = 0.27556 / (0.15208 / 8) = 14.4955.
// p from scipy.stats.f_oneway on the same lists: 0.0051825 (mu_s), 0.0087457 (mu_d),
// 0.00019004 (k_c), 0.091859 (k_e): "p < 0.05" for the first three, "p > 0.05" for k_e, as printed.
TEST(Stats, AnovaReproducesThePapersTables) {
  struct Case {
    std::vector<double> mild, severe;
    double f, p;
  };
  const Case cases[] = {
      {{0.06, 0.28, 0.19, 0.17, 0.19}, {0.21, 0.51, 0.54, 0.65, 0.64}, 14.496, 0.0051825149100718755},
      {{0.08, 0.24, 0.19, 0.21, 0.15}, {0.16, 0.47, 0.52, 0.60, 0.52}, 11.875, 0.008745650066063296},
      {{0.38, 0.68, 0.61, 0.60, 0.62}, {0.2, 0.18, 0.18, 0.13, 0.3}, 42.124, 0.00019004260993015545},
      {{0.3, 0.58, 0.53, 0.7, 0.53}, {0.37, 0.33, 0.43, 0.5, 0.3}, 3.666, 0.09185932204980551},
  };
  for (const Case& c : cases) {
    const Anova a = one_way_anova({c.mild, c.severe});
    EXPECT_EQ(a.df1, 1);
    EXPECT_EQ(a.df2, 8);
    ASSERT_TRUE(a.f && a.p) << a.note;
    EXPECT_NEAR(*a.f, c.f, 0.0006);  // the paper prints three decimals
    EXPECT_NEAR(*a.p, c.p, 1e-9);
  }
}

TEST(Stats, OneGroupHasNoF) {
  const Anova a = one_way_anova({{0.2, 0.3, 0.4}, {}});
  EXPECT_EQ(a.groups, 1U);
  EXPECT_EQ(a.df1, 0);
  EXPECT_FALSE(a.f);
  EXPECT_FALSE(a.p);
  EXPECT_NE(a.note.find("one group"), std::string::npos) << a.note;
}

// {0.2} and {0.5}: a group with one value each leaves N - k = 0 within-group degrees of freedom.
TEST(Stats, GroupsOfOneValueHaveNoWithinDegreesOfFreedom) {
  const Anova a = one_way_anova({{0.2}, {0.5}});
  EXPECT_EQ(a.df1, 1);
  EXPECT_EQ(a.df2, 0);
  EXPECT_NEAR(a.ss_between, 0.045, 1e-15);  // 2 x (0.15)^2
  EXPECT_FALSE(a.f);
  EXPECT_NE(a.note.find("degrees of freedom"), std::string::npos) << a.note;
}

// One group of one value beside a larger group is fine: df2 = 3 + 1 - 2 = 2.
// A = {1, 2, 3} mean 2, B = {6}: grand mean 3; SS_between = 3 (1) + 1 (9) = 12; SS_within = 2;
// F = (12 / 1) / (2 / 2) = 12; p = P(F(1, 2) > 12) = 1 - sqrt(12 / 14) (for df1 = 1, df2 = 2 the tail
// is 1 - sqrt(f / (f + 2))) = 0.0741799...
TEST(Stats, AGroupWithOneValueBesideALargerOne) {
  const Anova a = one_way_anova({{1, 2, 3}, {6}});
  EXPECT_EQ(a.df2, 2);
  ASSERT_TRUE(a.f && a.p) << a.note;
  EXPECT_NEAR(*a.f, 12.0, 1e-12);
  EXPECT_NEAR(*a.p, 1.0 - std::sqrt(12.0 / 14.0), 1e-12);
}

TEST(Stats, ZeroVarianceWithinGroupsIsReportedNotInfinite) {
  const Anova a = one_way_anova({{0.3, 0.3, 0.3}, {0.5, 0.5}});
  EXPECT_GT(a.ss_between, 0.0);
  EXPECT_FALSE(a.f);
  EXPECT_FALSE(a.p);
  EXPECT_NE(a.note.find("zero variance"), std::string::npos) << a.note;
  const Anova same = one_way_anova({{0.0, 0.0}, {0.0, 0.0}});
  EXPECT_FALSE(same.f);
}

// x = {1, 2, 3, 4}, y = {2, 3, 3, 5}: mean x 2.5, mean y 3.25; sum (x - 2.5)(y - 3.25) =
// (-1.5)(-1.25) + (-0.5)(-0.25) + (0.5)(-0.25) + (1.5)(1.75) = 1.875 + 0.125 - 0.125 + 2.625 = 4.5;
// sum (x - 2.5)^2 = 2.25 + 0.25 + 0.25 + 2.25 = 5; slope 0.9.
TEST(Stats, LeastSquaresSlopeByHand) {
  const std::optional<double> slope = least_squares_slope({1, 2, 3, 4}, {2, 3, 3, 5});
  ASSERT_TRUE(slope);
  EXPECT_NEAR(*slope, 0.9, 1e-15);
  EXPECT_FALSE(least_squares_slope({1}, {2}));
  EXPECT_FALSE(least_squares_slope({2, 2}, {1, 3}));
  EXPECT_THROW(least_squares_slope({1, 2}, {1}), Error);
}

TEST(Stats, FDistributionTailChecksItsArguments) {
  EXPECT_NEAR(f_distribution_upper_tail(0.0, 1, 8), 1.0, 1e-15);
  EXPECT_THROW(f_distribution_upper_tail(-1.0, 1, 8), Error);
  EXPECT_THROW(f_distribution_upper_tail(2.0, 0, 8), Error);
  EXPECT_THROW(f_distribution_upper_tail(std::numeric_limits<double>::quiet_NaN(), 1, 8), Error);
}

}  // namespace
}  // namespace cariesim::training
