#pragma once
/// The step's Params: what may change while the servo loop runs (docs/style.md "Model / State / step"). The
/// Model is immutable once built; the materials a slider or a study tunes, the coupling gains and the
/// device's limits live in a Params block instead. The Model carries the authored one
/// (Model::defaults); whoever runs the step owns the running copy (the servo thread in the simulator,
/// a local copy in an experiment) and passes it to step().
///
/// One set of rules validates every value, wherever it comes from: the scene parser, the viewer's
/// sliders, a study, the UDP bridge's announced limits (check_material, check_limits). The checks and
/// apply_param_change allocate nothing, so the servo thread can use them between two steps.

#include <cstdint>
#include <vector>

#include "cariesim/device/limits.hpp"
#include "cariesim/render/material.hpp"

namespace cariesim {

/// Virtual coupling between haptic and graphic tool: the weight G of paper eqs. 1-2.
struct CouplingGains {
  double k_trans = 1.0;  ///< N/mm (at most the device's maximum stiffness, eq. 6 k_p)
  double k_rot = 150.0;  ///< N·mm/rad
};

struct Params {
  /// Indexed by SphereNode::material; the Model fixes the count and which materials are rigid.
  std::vector<Material> materials;
  CouplingGains gains;
  DeviceLimits limits;  ///< the device's, as announced (never above the scene's)
};

/// Bounds shared by every source of values.
inline constexpr double kMaxFriction = 5.0;      ///< largest friction coefficient
inline constexpr double kMaxStiffness = 1e6;     ///< N/mm (also N·mm/rad for k_θ)
inline constexpr double kMaxThreshold = 1e3;     ///< N, largest F_p* or F_e*
inline constexpr double kMaxDeviceForce = 1e3;   ///< N, largest force limit a device may announce
inline constexpr double kMaxDeviceTorque = 1e5;  ///< N·mm, largest torque limit a device may announce
/// Smallest limits a device may have: below them the rendered wrench is too weak to feel, so a limit
/// of 1e-300 N would zero it with no flag saying why (N, N/mm, N·mm).
inline constexpr double kMinDeviceForce = 0.1;
inline constexpr double kMinDeviceStiffness = 0.01;
inline constexpr double kMinDeviceTorque = 1.0;

/// What is wrong with a value: the field as scene files name it, and the rule it breaks (static
/// strings). Empty (false) when nothing is.
struct ParamProblem {
  const char* field = nullptr;
  const char* rule = nullptr;
  explicit operator bool() const { return field != nullptr; }
};

/// Checks a material's values: friction in [0, kMaxFriction]; stiffness > 0 (infinite = rigid);
/// k_e, k_θ and every k_c in (0, kMaxStiffness]; F_p*, F_e* in [0, kMaxThreshold]; k_c layer bounds
/// increasing. Allocation-free.
ParamProblem check_material(const Material& material);
/// Checks device limits: force in [kMinDeviceForce, kMaxDeviceForce] N, stiffness in
/// [kMinDeviceStiffness, kMaxStiffness] N/mm, torque in [kMinDeviceTorque, kMaxDeviceTorque] N·mm,
/// resolution in [0, 1000] mm, a finite, non-empty workspace. Allocation-free.
ParamProblem check_limits(const DeviceLimits& limits);

/// The Params a device's limits allow: `authored` with limits tightened to `device` (eq. 6's k_p is
/// then the device's maximum stiffness) and the coupling stiffness no higher than that.
Params with_device_limits(const Params& authored, const DeviceLimits& device);

/// A parameter change from the UI, a study or the bridge, applied between two steps.
struct ParamChange {
  /// μs, μd (1); Stiffness: contact stiffness, KE: k_e, KC: constant k_c (N/mm); FPStar: F_p*,
  /// FEStar: F_e* (N); KTheta: k_θ (N·mm/rad); ForceScale (1, in [0, 1]; not a Params value: the
  /// servo loop gives it to its ForceSafety); Preset: the paper's mild (0) or severe (1) preset
  /// (caries_preset).
  enum class Field : uint8_t { MuS, MuD, Stiffness, KE, KC, FPStar, FEStar, KTheta, ForceScale, Preset };
  Field field = Field::MuS;
  int16_t lesion = -1;  ///< the lesion whose materials change; -1 for ForceScale
  double value = 0.0;   ///< in the field's unit (N/mm, N, N·mm/rad, 1); Preset: 0 mild, 1 severe
};

/// Applies a change to every material of the change's lesion. Returns false, changing nothing, when
/// it does not apply: no material of that lesion, ForceScale, or a result check_material refuses.
/// Allocation-free.
bool apply_param_change(Params& params, const ParamChange& change);

}  // namespace cariesim
