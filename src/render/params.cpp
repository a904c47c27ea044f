// The rules every tunable value follows (render/params.hpp), and parameter changes between steps.
#include "cariesim/render/params.hpp"

#include <algorithm>
#include <cmath>

namespace cariesim {

namespace {

bool in_range(double v, double lo, double hi, bool lo_open) {
  return std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
}

bool friction_ok(double mu) { return in_range(mu, 0.0, kMaxFriction, false); }
bool stiffness_ok(double k) { return in_range(k, 0.0, kMaxStiffness, true); }
bool threshold_ok(double f) { return in_range(f, 0.0, kMaxThreshold, false); }

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
      m.crush_length = preset.crush_length;
      m.f_p_star = preset.f_p_star;
      m.f_e_star = preset.f_e_star;
      break;
    case F::ForceScale:
      break;
  }
}

}  // namespace

ParamProblem check_material(const Material& m) {
  // Contact stiffness: positive; infinite means rigid.
  if (!(m.stiffness > 0.0) || (std::isfinite(m.stiffness) && m.stiffness > kMaxStiffness))
    return {"stiffness", "must be > 0 and at most 1e6 N/mm (or rigid)"};
  // Friction coefficients, across and along an anisotropy direction.
  if (!friction_ok(m.mu_s)) return {"mu_s", "must be in [0, 5]"};
  if (!friction_ok(m.mu_d)) return {"mu_d", "must be in [0, 5]"};
  if (!m.aniso_dir.allFinite()) return {"anisotropic.direction", "must be finite"};
  if (!friction_ok(m.mu_s_along)) return {"anisotropic.mu_s", "must be in [0, 5]"};
  if (!friction_ok(m.mu_d_along)) return {"anisotropic.mu_d", "must be in [0, 5]"};
  // Penetration parameters (eqs. 3-9, Fig. 6).
  if (!stiffness_ok(m.k_e)) return {"k_e", "must be in (0, 1e6] N/mm"};
  if (!stiffness_ok(m.k_theta)) return {"k_theta", "must be in (0, 1e6] N·mm/rad"};
  if (!threshold_ok(m.f_p_star)) return {"f_p_star", "must be in [0, 1000] N"};
  if (!threshold_ok(m.f_e_star)) return {"f_e_star", "must be in [0, 1000] N"};
  if (!(std::isfinite(m.crush_length) && m.crush_length > 0.0 && m.crush_length <= 100.0))
    return {"crush_length", "must be in (0, 100] mm"};
  const KcProfile& k = m.k_c;
  if (k.layer_count < 1 || k.layer_count > KcProfile::kMaxLayers) return {"k_c", "must have 1 to 4 layers"};
  const int used = k.kind == KcProfile::Kind::Gradient ? 2
                   : k.kind == KcProfile::Kind::Layers ? k.layer_count
                                                       : 1;
  for (int i = 0; i < used; ++i)
    if (!stiffness_ok(k.values[i])) return {"k_c", "every k_c must be in (0, 1e6] N/mm"};
  if (k.kind == KcProfile::Kind::Layers) {
    for (int i = 0; i + 1 < k.layer_count; ++i) {
      const double lo = i == 0 ? 0.0 : k.bounds[i - 1];
      if (!(std::isfinite(k.bounds[i]) && k.bounds[i] > lo))
        return {"k_c.layers", "layer bottoms must increase"};
    }
  }
  if (k.kind == KcProfile::Kind::Gradient && !(std::isfinite(k.bounds[0]) && k.bounds[0] > 0.0))
    return {"k_c.gradient.depth", "must be > 0 mm"};
  return {};
}

ParamProblem check_limits(const DeviceLimits& l) {
  if (!in_range(l.max_force, kMinDeviceForce, kMaxDeviceForce, false))
    return {"max_force", "must be in [0.1, 1000] N"};
  if (!in_range(l.max_stiffness, kMinDeviceStiffness, kMaxStiffness, false))
    return {"max_stiffness", "must be in [0.01, 1e6] N/mm"};
  if (!in_range(l.max_torque, kMinDeviceTorque, kMaxDeviceTorque, false))
    return {"max_torque", "must be in [1, 1e5] N·mm"};
  if (!in_range(l.position_resolution, 0.0, 1000.0, false))
    return {"position_resolution", "must be in [0, 1000] mm"};
  if (!(l.workspace.min().allFinite() && l.workspace.max().allFinite()) || l.workspace.isEmpty())
    return {"workspace", "must be a finite, non-empty box"};
  return {};
}

Params with_device_limits(const Params& authored, const DeviceLimits& device) {
  Params p = authored;
  p.limits = tighter(authored.limits, device);
  p.gains.k_trans = std::min(authored.gains.k_trans, p.limits.max_stiffness);
  return p;
}

bool apply_param_change(Params& params, const ParamChange& change) {
  using F = ParamChange::Field;
  if (change.field == F::ForceScale || change.lesion < 0) return false;
  if (change.field == F::Preset && change.value != 0.0 && change.value != 1.0) return false;
  const Material preset = change.field == F::Preset
                              ? caries_preset(change.value == 0.0 ? CariesPreset::Mild : CariesPreset::Severe)
                              : Material{};
  // Every material of the lesion (all its layers) must accept the change before any is changed; a
  // material never turns from compliant to rigid or back (the Model fixed that).
  bool any = false;
  for (const Material& m : params.materials) {
    if (m.lesion != change.lesion) continue;
    Material changed = m;
    set_field(changed, change, preset);
    if (check_material(changed) || changed.rigid() != m.rigid()) return false;
    any = true;
  }
  if (!any) return false;
  for (Material& m : params.materials)
    if (m.lesion == change.lesion) set_field(m, change, preset);
  return true;
}

}  // namespace cariesim
