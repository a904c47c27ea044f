// Force shading (docs/step.md, "Force shading"): a frictionless slide over the real arch's scanned
// enamel (tooth 46's buccal surface, experiment/enamel_slide.hpp) at 0.6 N and 5 mm/s renders a smooth
// surface. With the sphere pairs' own normals (force shading off, as before it existed) each inscribed
// sphere tilted the contact normal and the tangential force rippled 0.1-0.2 N peak-to-peak over 0.5 mm,
// more than the friction of a mild lesion at that load.
#include "experiment/enamel_slide.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include "cariesim/render/material.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

Model& real_arch() {
  static Model model = build_model(load_scene("real-arch"));
  return model;
}

Params frictionless(const Model& m) {
  Params p = m.defaults;
  for (Material& mat : p.materials) mat.mu_s = mat.mu_d = mat.mu_s_along = mat.mu_d_along = 0.0;
  return p;
}

experiment::EnamelSlide slide_with(bool shading) {
  Model& m = real_arch();
  const bool by_default = m.settings.force_shading;
  m.settings.force_shading = shading;
  experiment::EnamelSlide slide = experiment::enamel_slide(m, frictionless(m));
  m.settings.force_shading = by_default;
  std::printf(
      "force shading %s: ripple %.4f N over %.2f mm, mean normal %.3f N, %zu free steps, rigid %.4f mm\n",
      shading ? "on" : "off", slide.ripple, slide.s.empty() ? 0.0 : slide.s.back() - slide.s.front(),
      slide.mean_normal, slide.free_steps.size(), slide.max_rigid_penetration);
  return slide;
}

TEST(EnamelSlide, FrictionlessScannedEnamelIsSmooth) {
  const experiment::EnamelSlide slide = slide_with(true);
  ASSERT_GT(slide.s.size(), 500u);
  EXPECT_GT(slide.s.back() - slide.s.front(), 3.5);                    // mm slid
  EXPECT_NEAR(slide.mean_normal, experiment::kEnamelSlideLoad, 0.05);  // N: the load
  EXPECT_TRUE(slide.free_steps.empty());                               // the tip stays on the enamel
  EXPECT_LT(slide.ripple, 0.02);  // N peak-to-peak, along or across the slide, over any 0.5 mm
  EXPECT_LE(slide.max_rigid_penetration, real_arch().settings.rigid_tolerance + 1e-9);
  // The presets' friction at this load is at least three times the ripple: mild caries feels rougher
  // than healthy enamel (paper Table 1's roughness cue).
  for (const CariesPreset preset : {CariesPreset::Mild, CariesPreset::Severe})
    EXPECT_GE(caries_preset(preset).mu_d * experiment::kEnamelSlideLoad, 3.0 * slide.ripple);
}

TEST(EnamelSlide, SphereNormalsAloneRippleOnTheSameSlide) {
  // The measure sees the inscribed spheres when the rows take their normals (force shading off).
  const experiment::EnamelSlide off = slide_with(false);
  const experiment::EnamelSlide on = slide_with(true);
  EXPECT_GT(off.ripple, 0.05);
  EXPECT_GT(off.ripple, 3.0 * on.ripple);
}

}  // namespace
}  // namespace cariesim
