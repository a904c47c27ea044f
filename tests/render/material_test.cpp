#include "cariesim/render/material.hpp"

#include <gtest/gtest.h>

namespace cariesim {
namespace {

TEST(KcProfile, ConstantIsFlat) {
  KcProfile p;
  p.values.fill(10.0);
  EXPECT_DOUBLE_EQ(p.at(0.0), 10.0);
  EXPECT_DOUBLE_EQ(p.at(3.0), 10.0);
}

TEST(KcProfile, LayersStepAtTheBoundary) {
  KcProfile p;
  p.kind = KcProfile::Kind::Layers;
  p.layer_count = 2;
  p.values = {5.0, 20.0, 0.0, 0.0};
  p.bounds = {1.0, 3.0, 0.0, 0.0};
  EXPECT_DOUBLE_EQ(p.at(0.5), 5.0);
  EXPECT_DOUBLE_EQ(p.at(1.5), 20.0);
  EXPECT_DOUBLE_EQ(p.at(9.0), 20.0);  // below the last layer: the deepest value holds
}

TEST(KcProfile, GradientIsLinearAndClamped) {
  KcProfile p;
  p.kind = KcProfile::Kind::Gradient;
  p.values = {2.0, 6.0, 0.0, 0.0};
  p.bounds = {2.0, 0.0, 0.0, 0.0};
  EXPECT_DOUBLE_EQ(p.at(1.0), 4.0);
  EXPECT_DOUBLE_EQ(p.at(5.0), 6.0);
}

TEST(Material, PresetsFollowTheTables) {
  const Material mild = caries_preset(CariesPreset::Mild);
  const Material severe = caries_preset(CariesPreset::Severe);
  EXPECT_DOUBLE_EQ(mild.mu_s, 0.18);
  EXPECT_DOUBLE_EQ(severe.mu_d, 0.45);
  EXPECT_DOUBLE_EQ(mild.k_c.at(0.0), 0.58);
  EXPECT_DOUBLE_EQ(severe.k_e, 0.38);
  EXPECT_GT(mild.f_p_star, severe.f_p_star);  // mild decay is harder to enter (§3.1)
  EXPECT_FALSE(mild.rigid());
}

TEST(Tissue, NamesRoundTrip) {
  Tissue t{};
  ASSERT_TRUE(parse_tissue("gingiva", t));
  EXPECT_EQ(t, Tissue::Gingiva);
  EXPECT_EQ(tissue_name(Tissue::Dentin), "dentin");
  EXPECT_FALSE(parse_tissue("bone", t));
}

}  // namespace
}  // namespace cariesim
