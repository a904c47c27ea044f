#pragma once
/// The one judge of a device reading (docs/step.md "Input"): is its pose a pose (finite, a unit
/// quaternion), did the device call it valid, is it fresh, did it jump. One parameter set,
/// InputLimits, serves every reader of the verdict: the haptic step keeps the guard in its state and
/// flags what it found (kFlagNonFiniteInput, kFlagJumpLimited, StepOutput::input_faults), the force
/// safety layer zeroes the wrench on the same verdict (ForceSafety::filter), and the UDP bridge's
/// largest transit delay is its staleness (the device factory passes it). The bridge's parser and the
/// trajectory files use its rule for a unit quaternion (is_unit).
///
/// Header only, allocation-free: the engine (render) uses it without linking the device library.

#include <cmath>
#include <cstdint>

#include "cariesim/common/math.hpp"

namespace cariesim {

/// How far a quaternion's length may be from 1 and still be taken for a rotation: | |q| - 1 |.
/// Rounding in a file written with a few digits or in a device's single-precision numbers, not a
/// pose that means something else.
inline constexpr double kUnitTolerance = 1e-3;

/// The limits readings are judged by, one set for the step, force safety and the UDP bridge
/// (Model::settings.input holds the scene's).
struct InputLimits {
  double max_jump = 20.0;          ///< mm, a larger move between two readings is a jump
  double max_jump_rotation = 0.5;  ///< rad, a larger turn between two readings is a jump
  /// s, a reading older than this is stale; also the UDP bridge's largest accepted transit delay
  double stale_after = 0.05;
};

/// What is wrong with a reading (InputGuard::judge); 0 when nothing.
enum InputFault : uint32_t {
  kInputInvalid = 1u << 0,    ///< the device marked it invalid (no reading yet, or its source ended)
  kInputNonFinite = 1u << 1,  ///< its pose is not finite, or its quaternion not unit (is_unit)
  kInputStale = 1u << 2,      ///< older than InputLimits::stale_after
  kInputJump = 1u << 3,       ///< moved (turned) further than max_jump (max_jump_rotation) from the
                              ///< pose used before
};

/// True when q's length is 1 within kUnitTolerance (false for a non-finite q).
inline bool is_unit(const Quat& q) { return std::abs(q.norm() - 1.0) <= kUnitTolerance; }

/// True when `pose` can be used: a finite position and a finite unit quaternion (is_unit).
inline bool usable_pose(const Pose& pose) {
  return pose.p.allFinite() && pose.q.coeffs().allFinite() && is_unit(pose.q);
}

/// The guard of one stream of readings: it remembers the pose it let through last. Allocation-free.
class InputGuard {
 public:
  /// `limits` as given, out-of-range values brought into range (negative ones become 0, non-finite
  /// ones the defaults); `start` is the pose used until a reading can be (normalised).
  explicit InputGuard(const InputLimits& limits = {}, const Pose& start = {})
      : limits_(sane(limits)), pose_(start) {}

  /// Judges a reading: its pose, whether the device called it valid, its age (s, servo time now minus
  /// the reading's stamp). Returns InputFault bits. pose() is then the pose to use: the reading's,
  /// normalised, unless it is invalid or not usable, when the pose used before stays. A jump is
  /// measured from the pose used before (never at the first reading).
  uint32_t judge(const Pose& pose, bool valid = true, double age = 0.0) {
    uint32_t faults = 0;
    if (!valid) faults |= kInputInvalid;
    if (!usable_pose(pose)) faults |= kInputNonFinite;
    if (!(age <= limits_.stale_after)) faults |= kInputStale;
    Pose next = (faults & (kInputInvalid | kInputNonFinite)) == 0 ? pose : pose_;
    next.q.normalize();
    if (judged_ && ((next.p - pose_.p).norm() > limits_.max_jump ||
                    next.q.angularDistance(pose_.q) > limits_.max_jump_rotation))
      faults |= kInputJump;
    pose_ = next;
    judged_ = true;
    return faults;
  }

  /// The pose to use after the last judge() (the start pose before any).
  [[nodiscard]] const Pose& pose() const { return pose_; }
  /// The limits in force (after bringing them into range).
  [[nodiscard]] const InputLimits& limits() const { return limits_; }
  /// Forgets the readings: the next one is not measured for a jump; pose() stays.
  void reset() { judged_ = false; }

  /// `limits` with negative values as 0 (the safe side) and non-finite ones as the defaults.
  static InputLimits sane(const InputLimits& limits) {
    const InputLimits defaults;
    const auto fix = [](double value, double fallback) {
      return std::isfinite(value) ? (value < 0.0 ? 0.0 : value) : fallback;
    };
    return {fix(limits.max_jump, defaults.max_jump),
            fix(limits.max_jump_rotation, defaults.max_jump_rotation),
            fix(limits.stale_after, defaults.stale_after)};
  }

 private:
  InputLimits limits_;
  Pose pose_;
  bool judged_ = false;
};

}  // namespace cariesim
