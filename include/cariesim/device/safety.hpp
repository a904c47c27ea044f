#pragma once
/// The force safety layer every device goes through (DESIGN.md §5): clamp force and torque to the
/// device's limits, ramp in at start, zero force when the input is stale or not finite, a global
/// force scale. Allocation-free; used on the servo thread.
///
/// A reading is a fault, and the wrench is zeroed, when it is marked invalid, is not finite (pose,
/// or the wrench itself), is older than `stale_after`, or jumped further than `max_jump` from the
/// previous reading. After a fault clears the force ramps in again from zero over `ramp_time`, as
/// at start. The scale applies before the clamp, so the rendered force never exceeds the limits.

#include <cstdint>

#include "cariesim/device/device.hpp"

namespace cariesim {

struct SafetyParams {
  double max_force = 22.0;    ///< N (Phantom Premium 3.0 6-DoF)
  double max_torque = 500.0;  ///< N·mm
  double ramp_time = 1.0;     ///< s, from zero to full force after start (and after a fault clears)
  double stale_after = 0.05;  ///< s, a reading older than this zeroes the force
  double force_scale = 1.0;   ///< global scale in [0, 1]
  double max_jump = 20.0;     ///< mm, a larger move between two readings is a fault
};

/// Why the last wrench was changed.
enum SafetyFlag : uint32_t {
  kSafetyClampedForce = 1u << 0,
  kSafetyClampedTorque = 1u << 1,
  kSafetyRamping = 1u << 2,
  kSafetyStale = 1u << 3,
  kSafetyNonFinite = 1u << 4,
  kSafetyInvalidInput = 1u << 5,
  kSafetyJump = 1u << 6,  ///< the reading jumped further than SafetyParams::max_jump
};
/// The flags that mean the force was zeroed.
inline constexpr uint32_t kSafetyFaultMask =
    kSafetyStale | kSafetyNonFinite | kSafetyInvalidInput | kSafetyJump;

class ForceSafety {
 public:
  /// Takes the parameters; out-of-range values are brought into range (negative limits become 0,
  /// the scale is clamped to [0, 1], non-finite values fall back to the defaults).
  explicit ForceSafety(const SafetyParams& params = {});
  /// Filters a wrench for the reading `input` at servo time `now` (s). Returns the wrench to render.
  void filter(Vec3& force, Vec3& torque, const DeviceState& input, double now);
  [[nodiscard]] uint32_t flags() const { return flags_; }    ///< SafetyFlag bits of the last call
  [[nodiscard]] uint64_t faults() const { return faults_; }  ///< calls that zeroed the force
  /// Sets the global scale; clamped to [0, 1], a non-finite value gives 0.
  void set_force_scale(double scale);
  [[nodiscard]] const SafetyParams& params() const { return params_; }
  /// Forgets the previous reading and restarts the ramp (a new start of the loop); keeps the counter.
  void reset();

 private:
  SafetyParams params_;
  double ramp_start_ = -1.0;           // s; negative = not started
  Vec3 last_position_ = Vec3::Zero();  // mm, the previous finite reading
  bool has_last_ = false;
  uint32_t flags_ = 0;
  uint64_t faults_ = 0;
};

}  // namespace cariesim
