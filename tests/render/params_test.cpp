// Params: apply_param_change reaches every material of the lesion and nothing else, bad changes are
// refused and change nothing; check_material and check_limits name what is wrong; device limits
// tighten the authored ones.
#include "cariesim/render/params.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace cariesim {
namespace {

// Two lesions: lesion 0 has two materials (layers), lesion 1 one; plus one healthy material.
Params two_lesion_model() {
  Params m;
  Material healthy;
  healthy.tissue = Tissue::Enamel;
  m.materials.push_back(healthy);
  for (int16_t lesion : {0, 0, 1}) {
    Material c;
    c.tissue = Tissue::Caries;
    c.stiffness = 1.0;
    c.lesion = lesion;
    m.materials.push_back(c);
  }
  return m;
}

using F = ParamChange::Field;

TEST(ApplyParamChange, EachFieldReachesEveryMaterialOfTheLesion) {
  struct Case {
    F field;
    double value;
    double (*get)(const Material&);
  };
  const Case cases[] = {
      {F::MuS, 0.7, [](const Material& m) { return m.mu_s; }},
      {F::MuD, 0.4, [](const Material& m) { return m.mu_d; }},
      {F::Stiffness, 2.5, [](const Material& m) { return m.stiffness; }},
      {F::KE, 0.9, [](const Material& m) { return m.k_e; }},
      {F::KC, 3.5, [](const Material& m) { return m.k_c.at(0.7); }},
      {F::FPStar, 4.5, [](const Material& m) { return m.f_p_star; }},
      {F::FEStar, 1.5, [](const Material& m) { return m.f_e_star; }},
      {F::KTheta, 250.0, [](const Material& m) { return m.k_theta; }},
  };
  for (const Case& c : cases) {
    Params m = two_lesion_model();
    const Params before = m;
    ASSERT_TRUE(apply_param_change(m, ParamChange{c.field, 0, c.value})) << static_cast<int>(c.field);
    EXPECT_DOUBLE_EQ(c.get(m.materials[1]), c.value);
    EXPECT_DOUBLE_EQ(c.get(m.materials[2]), c.value);
    // The other lesion and the healthy material keep their values.
    EXPECT_DOUBLE_EQ(c.get(m.materials[3]), c.get(before.materials[3]));
    EXPECT_DOUBLE_EQ(c.get(m.materials[0]), c.get(before.materials[0]));
  }
}

TEST(ApplyParamChange, KcBecomesConstantOverDepth) {
  Params m = two_lesion_model();
  m.materials[1].k_c.kind = KcProfile::Kind::Layers;
  m.materials[1].k_c.values = {0.3, 0.2, 0.2, 0.2};
  m.materials[1].k_c.bounds = {1.5, 2.5, 0.0, 0.0};
  m.materials[1].k_c.layer_count = 2;
  ASSERT_TRUE(apply_param_change(m, ParamChange{F::KC, 0, 0.8}));
  for (double depth : {0.0, 1.0, 2.0, 5.0}) EXPECT_DOUBLE_EQ(m.materials[1].k_c.at(depth), 0.8);
}

TEST(ApplyParamChange, PresetsAreThePapers) {
  for (const auto& [value, preset] :
       {std::pair{0.0, CariesPreset::Mild}, std::pair{1.0, CariesPreset::Severe}}) {
    Params m = two_lesion_model();
    m.materials[2].aniso_dir = Vec3::UnitX();
    m.materials[2].mu_s_along = 0.9;
    ASSERT_TRUE(apply_param_change(m, ParamChange{F::Preset, 0, value}));
    const Material p = caries_preset(preset);
    for (int i : {1, 2}) {
      const Material& got = m.materials[i];
      EXPECT_DOUBLE_EQ(got.mu_s, p.mu_s);
      EXPECT_DOUBLE_EQ(got.mu_d, p.mu_d);
      EXPECT_DOUBLE_EQ(got.k_e, p.k_e);
      EXPECT_DOUBLE_EQ(got.stiffness, p.stiffness);
      EXPECT_DOUBLE_EQ(got.k_c.at(1.0), p.k_c.at(1.0));
      EXPECT_DOUBLE_EQ(got.f_p_star, p.f_p_star);
      EXPECT_DOUBLE_EQ(got.f_e_star, p.f_e_star);
      EXPECT_EQ(got.lesion, 0);  // still the lesion's material
      EXPECT_TRUE(got.aniso_dir.isZero());
    }
  }
}

TEST(ApplyParamChange, RefusesBadChangesAndChangesNothing) {
  const ParamChange bad[] = {
      {F::MuS, 2, 0.5},          // no such lesion
      {F::MuS, -1, 0.5},         // no lesion
      {F::MuS, 0, -0.1},         // negative friction
      {F::MuD, 0, 6.0},          // beyond range
      {F::Stiffness, 0, 0.0},    // must be > 0
      {F::KE, 0, std::nan("")},  // not finite
      {F::KC, 0, -1.0},         {F::KTheta, 0, 1e300},
      {F::FPStar, 0, -2.0},     {F::FEStar, 0, std::numeric_limits<double>::infinity()},
      {F::Preset, 0, 0.5},       // neither mild nor severe
      {F::ForceScale, -1, 0.5},  // the loop's, not the model's
  };
  for (const ParamChange& c : bad) {
    Params m = two_lesion_model();
    EXPECT_FALSE(apply_param_change(m, c)) << static_cast<int>(c.field) << " " << c.value;
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
      EXPECT_DOUBLE_EQ(m.materials[i].mu_s, two_lesion_model().materials[i].mu_s);
      EXPECT_DOUBLE_EQ(m.materials[i].k_e, two_lesion_model().materials[i].k_e);
      EXPECT_DOUBLE_EQ(m.materials[i].stiffness, two_lesion_model().materials[i].stiffness);
    }
  }
}

TEST(ApplyParamChange, NeverTurnsACompliantMaterialRigid) {
  Params m = two_lesion_model();
  EXPECT_FALSE(apply_param_change(m, ParamChange{F::Stiffness, 0, std::numeric_limits<double>::infinity()}));
  EXPECT_DOUBLE_EQ(m.materials[1].stiffness, 1.0);
}

TEST(CheckMaterial, NamesTheFieldThatBreaksARule) {
  EXPECT_FALSE(check_material(caries_preset(CariesPreset::Mild)));
  EXPECT_FALSE(check_material(Material{}));  // rigid generic tissue
  struct Case {
    void (*mutate)(Material&);
    const char* field;
  };
  const Case cases[] = {
      {[](Material& m) { m.stiffness = 0.0; }, "stiffness"},
      {[](Material& m) { m.stiffness = 2e6; }, "stiffness"},
      {[](Material& m) { m.mu_s = 5.5; }, "mu_s"},
      {[](Material& m) { m.mu_d = std::nan(""); }, "mu_d"},
      {[](Material& m) { m.mu_s_along = -1.0; }, "anisotropic.mu_s"},
      {[](Material& m) { m.k_e = 0.0; }, "k_e"},
      {[](Material& m) { m.k_theta = -3.0; }, "k_theta"},
      {[](Material& m) { m.f_p_star = 1e4; }, "f_p_star"},
      {[](Material& m) { m.f_e_star = -1.0; }, "f_e_star"},
      {[](Material& m) { m.k_c.values[0] = 0.0; }, "k_c"},
      {[](Material& m) {
         m.k_c.kind = KcProfile::Kind::Layers;
         m.k_c.layer_count = 2;
         m.k_c.bounds = {2.0, 1.0, 0.0, 0.0};
         m.k_c.values = {1.0, 1.0, 1.0, 1.0};
         m.k_c.bounds[0] = 0.0;
       },
       "k_c.layers"},
  };
  for (const Case& c : cases) {
    Material m = caries_preset(CariesPreset::Severe);
    c.mutate(m);
    const ParamProblem problem = check_material(m);
    ASSERT_TRUE(problem) << c.field;
    EXPECT_STREQ(problem.field, c.field);
    EXPECT_NE(problem.rule, nullptr);
  }
}

TEST(CheckLimits, RefusesWhatNoDeviceCanBe) {
  EXPECT_FALSE(check_limits(DeviceLimits{}));
  DeviceLimits l;
  l.max_stiffness = 0.0;
  EXPECT_STREQ(check_limits(l).field, "max_stiffness");
  l = DeviceLimits{};
  l.max_force = std::numeric_limits<double>::infinity();
  EXPECT_STREQ(check_limits(l).field, "max_force");
  l = DeviceLimits{};
  l.workspace = Eigen::AlignedBox3d(Vec3(1, 1, 1), Vec3(0, 0, 0));
  EXPECT_STREQ(check_limits(l).field, "workspace");
}

TEST(WithDeviceLimits, TheDeviceCanOnlyLowerTheLimitsAndTheCoupling) {
  Params authored = two_lesion_model();
  authored.gains.k_trans = 1.0;
  DeviceLimits device;
  device.max_stiffness = 0.01;
  device.max_force = 40.0;  // above the scene's 22 N: ignored
  const Params p = with_device_limits(authored, device);
  EXPECT_DOUBLE_EQ(p.limits.max_stiffness, 0.01);
  EXPECT_DOUBLE_EQ(p.limits.max_force, 22.0);
  EXPECT_DOUBLE_EQ(p.gains.k_trans, 0.01);
  EXPECT_DOUBLE_EQ(p.gains.k_rot, authored.gains.k_rot);
  EXPECT_EQ(p.materials.size(), authored.materials.size());
}

}  // namespace
}  // namespace cariesim
