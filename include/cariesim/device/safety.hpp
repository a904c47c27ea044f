#pragma once
/// The force safety layer every device goes through (docs/design.md §5): ramp in at start, zero force when
/// the input is at fault or the wrench not finite, a global force scale. Allocation-free; used on the
/// servo thread.
///
/// The layer judges no reading itself: the input guard (device/input_guard.hpp) does, once, in the
/// haptic step, and its verdict (StepOutput::input_faults) comes in here. A reading that is invalid,
/// not finite, stale or jumped is a fault, as is a non-finite wrench or time, and the wrench is zeroed.
/// After a fault clears the force ramps in again from zero over `ramp_time`, as at start. The layer
/// only ever scales the wrench down (by at most 1) or zeroes it: the one clamp to the device's limits
/// is the haptic step's output stage (against Params::limits, which hold what the device announced),
/// so a wrench that went through both never exceeds the limits.

#include <cstdint>

#include "cariesim/common/math.hpp"

namespace cariesim {

/// How the safety layer scales the wrench (the limits readings are judged by are the input guard's,
/// InputLimits, one set for the step and the layer).
struct SafetyParams {
  double ramp_time = 1.0;    ///< s, from zero to full force after start (and after a fault clears)
  double force_scale = 1.0;  ///< global scale in [0, 1]
};

/// What force safety did to a cycle's wrench (ForceSafety::flags), as records (`safety_flags`) keep
/// it. Bits 0-1 are unused: the step's output stage is the one clamp, and its flags say so
/// (kFlagForceClamped, kFlagTorqueClamped).
enum SafetyFlag : uint32_t {
  kSafetyRamping = 1u << 2,       ///< ramping in after start or after a fault
  kSafetyStale = 1u << 3,         ///< the reading is older than InputLimits::stale_after; zeroed
  kSafetyNonFinite = 1u << 4,     ///< the reading or the wrench is not finite; zeroed
  kSafetyInvalidInput = 1u << 5,  ///< the reading is marked invalid (none yet, or ended); zeroed
  kSafetyJump = 1u << 6,          ///< the reading jumped (turned) further than InputLimits::max_jump
                                  ///< (max_jump_rotation); zeroed
  kSafetyStopped = 1u << 7,       ///< the process asked every force to stop (request_force_stop); zeroed
};
/// The flags that mean the force was zeroed.
inline constexpr uint32_t kSafetyFaultMask =
    kSafetyStale | kSafetyNonFinite | kSafetyInvalidInput | kSafetyJump | kSafetyStopped;

/// Stops every force of the process: from the next servo cycle on, every ForceSafety zeroes its
/// wrench (kSafetyStopped), whatever the other threads do. Async-signal-safe (one lock-free atomic):
/// the programs call it from their SIGINT/SIGTERM handlers and on a fatal signal, so a device renders
/// no force while the program shuts down or dies.
void request_force_stop() noexcept;
/// True once request_force_stop was called (until clear_force_stop).
bool force_stop_requested() noexcept;
/// Lets forces through again (a test, or a program that cancelled its shutdown).
void clear_force_stop() noexcept;

/// The safety filter of one servo loop (servo thread only, apart from the const accessors).
class ForceSafety {
 public:
  /// Takes the parameters; out-of-range values are brought into range (a negative ramp time becomes
  /// 0, the scale is clamped to [0, 1], non-finite values fall back to the defaults).
  explicit ForceSafety(const SafetyParams& params = {});
  /// Filters a wrench (N, N·mm) in place at servo time `now` (s), given the input guard's verdict on
  /// the cycle's reading (`input_faults`, InputFault bits): zeroed on a fault, otherwise scaled by
  /// the ramp and the global scale (never up).
  void filter(Vec3& force, Vec3& torque, uint32_t input_faults, double now);
  [[nodiscard]] uint32_t flags() const { return flags_; }    ///< SafetyFlag bits of the last call
  [[nodiscard]] uint64_t faults() const { return faults_; }  ///< calls that zeroed the force
  /// Sets the global scale; clamped to [0, 1], a non-finite value gives 0.
  void set_force_scale(double scale);
  /// The parameters in force (after bringing them into range).
  [[nodiscard]] const SafetyParams& params() const { return params_; }
  /// Restarts the ramp (a new start of the loop); keeps the counter.
  void reset();

 private:
  SafetyParams params_;
  double ramp_start_ = -1.0;  // s; negative = not started
  uint32_t flags_ = 0;
  uint64_t faults_ = 0;
};

}  // namespace cariesim
