#pragma once
/// The force safety layer every device goes through (DESIGN.md §5): clamp force and torque to the
/// device's limits, ramp in at start, zero force when the input is stale or not finite, a global
/// force scale. Allocation-free; used on the servo thread.

#include <cstdint>

#include "cariesim/device/device.hpp"

namespace cariesim {

struct SafetyParams {
  double max_force = 22.0;      ///< N (Phantom Premium 3.0 6-DoF)
  double max_torque = 500.0;    ///< N·mm
  double ramp_time = 1.0;       ///< s, from zero to full force after start (and after a fault clears)
  double stale_after = 0.05;    ///< s, a reading older than this zeroes the force
  double force_scale = 1.0;     ///< global scale in [0, 1]
};

/// Why the last wrench was changed.
enum SafetyFlag : uint32_t {
  kSafetyClampedForce = 1u << 0,
  kSafetyClampedTorque = 1u << 1,
  kSafetyRamping = 1u << 2,
  kSafetyStale = 1u << 3,
  kSafetyNonFinite = 1u << 4,
  kSafetyInvalidInput = 1u << 5,
};

class ForceSafety {
 public:
  explicit ForceSafety(const SafetyParams& params = {});
  /// Filters a wrench for the reading `input` at servo time `now` (s). Returns the wrench to render.
  void filter(Vec3& force, Vec3& torque, const DeviceState& input, double now);
  [[nodiscard]] uint32_t flags() const { return flags_; }   ///< SafetyFlag bits of the last call
  [[nodiscard]] uint64_t faults() const { return faults_; } ///< calls that zeroed the force
  void set_force_scale(double scale);
  [[nodiscard]] const SafetyParams& params() const { return params_; }

 private:
  SafetyParams params_;
  double ramp_start_ = -1.0;  // s; negative = not started
  uint32_t flags_ = 0;
  uint64_t faults_ = 0;
};

}  // namespace cariesim
