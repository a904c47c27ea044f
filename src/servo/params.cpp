#include <cmath>

#include "cariesim/servo/servo.hpp"

namespace cariesim {

namespace {

constexpr double kMaxFriction = 5.0;   // μ
constexpr double kMaxStiffness = 1e6;  // N/mm, also N·mm/rad for k_θ
constexpr double kMaxThreshold = 1e3;  // N

bool in_range(double v, double lo, double hi, bool lo_open) {
  return std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
}

// Whether `value` is acceptable for `field`.
bool valid_value(ParamChange::Field field, double value) {
  using F = ParamChange::Field;
  switch (field) {
    case F::MuS:
    case F::MuD:
      return in_range(value, 0.0, kMaxFriction, false);
    case F::Stiffness:
    case F::KE:
    case F::KC:
    case F::KTheta:
      return in_range(value, 0.0, kMaxStiffness, true);
    case F::FPStar:
    case F::FEStar:
      return in_range(value, 0.0, kMaxThreshold, false);
    case F::Preset:
      return value == 0.0 || value == 1.0;
    case F::ForceScale:
      return false;
  }
  return false;
}

// Writes one field of one material.
void set_field(Material& m, const ParamChange& change, const Material& preset) {
  using F = ParamChange::Field;
  switch (change.field) {
    case F::MuS:
      m.mu_s = change.value;
      break;
    case F::MuD:
      m.mu_d = change.value;
      break;
    case F::Stiffness:
      m.stiffness = change.value;
      break;
    case F::KE:
      m.k_e = change.value;
      break;
    case F::KC:
      m.k_c.kind = KcProfile::Kind::Constant;
      m.k_c.values.fill(change.value);
      m.k_c.bounds.fill(0.0);
      m.k_c.layer_count = 1;
      break;
    case F::FPStar:
      m.f_p_star = change.value;
      break;
    case F::FEStar:
      m.f_e_star = change.value;
      break;
    case F::KTheta:
      m.k_theta = change.value;
      break;
    case F::Preset:
      // The paper's isotropic presets (Tables 1-2): friction, k_e, stiffness, constant k_c, F_p*, F_e*.
      m.mu_s = preset.mu_s;
      m.mu_d = preset.mu_d;
      m.aniso_dir = Vec3::Zero();
      m.mu_s_along = 0.0;
      m.mu_d_along = 0.0;
      m.k_e = preset.k_e;
      m.stiffness = preset.stiffness;
      m.k_c = preset.k_c;
      m.f_p_star = preset.f_p_star;
      m.f_e_star = preset.f_e_star;
      break;
    case F::ForceScale:
      break;
  }
}

}  // namespace

bool apply_param_change(Model& model, const ParamChange& change) {
  // Check the target and the value before touching anything.
  if (change.lesion < 0 || static_cast<std::size_t>(change.lesion) >= model.lesions.size()) return false;
  if (!valid_value(change.field, change.value)) return false;
  const Material preset = change.field == ParamChange::Field::Preset
                              ? caries_preset(change.value == 0.0 ? CariesPreset::Mild : CariesPreset::Severe)
                              : Material{};
  // Every material of the lesion (all its layers).
  bool any = false;
  for (Material& m : model.materials) {
    if (m.lesion != change.lesion) continue;
    set_field(m, change, preset);
    any = true;
  }
  return any;
}

}  // namespace cariesim
