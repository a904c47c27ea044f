#include "cariesim/device/safety.hpp"

#include <algorithm>
#include <cmath>

namespace cariesim {

namespace {

// A negative value becomes 0 (the safe side), a non-finite one the fallback.
double sane(double value, double fallback) { return std::isfinite(value) ? std::max(value, 0.0) : fallback; }

}  // namespace

ForceSafety::ForceSafety(const SafetyParams& params) : params_(params) {
  const SafetyParams defaults;
  params_.ramp_time = sane(params.ramp_time, defaults.ramp_time);
  params_.stale_after = sane(params.stale_after, defaults.stale_after);
  params_.max_jump = sane(params.max_jump, defaults.max_jump);
  params_.max_jump_rotation = sane(params.max_jump_rotation, defaults.max_jump_rotation);
  set_force_scale(params.force_scale);
}

void ForceSafety::set_force_scale(double scale) {
  params_.force_scale = std::isfinite(scale) ? std::clamp(scale, 0.0, 1.0) : 0.0;
}

void ForceSafety::reset() {
  ramp_start_ = -1.0;
  has_last_ = false;
  flags_ = 0;
}

void ForceSafety::filter(Vec3& force, Vec3& torque, const DeviceState& input, double now) {
  flags_ = 0;
  // Faults: an invalid or non-finite reading, a non-finite wrench, a stale reading, a jump.
  if (!input.valid) flags_ |= kSafetyInvalidInput;
  const bool pose_finite = input.pose.finite();
  if (!pose_finite || !force.allFinite() || !torque.allFinite() || !std::isfinite(now))
    flags_ |= kSafetyNonFinite;
  if (!(now - input.stamp <= params_.stale_after)) flags_ |= kSafetyStale;
  if (pose_finite) {
    const Quat q = input.pose.q.normalized();
    if (has_last_ && ((input.pose.p - last_position_).norm() > params_.max_jump ||
                      q.angularDistance(last_orientation_) > params_.max_jump_rotation))
      flags_ |= kSafetyJump;
    last_position_ = input.pose.p;
    last_orientation_ = q;
    has_last_ = true;
  }
  if ((flags_ & kSafetyFaultMask) != 0) {
    force.setZero();
    torque.setZero();
    ++faults_;
    ramp_start_ = -1.0;  // ramp in again once the fault clears
    return;
  }

  // Ramp in from zero over ramp_time after start or after a fault, times the global scale.
  if (ramp_start_ < 0.0) ramp_start_ = now;
  double scale = params_.force_scale;
  const double elapsed = now - ramp_start_;
  if (elapsed < params_.ramp_time) {
    scale *= std::clamp(elapsed / params_.ramp_time, 0.0, 1.0);
    flags_ |= kSafetyRamping;
  }
  force *= scale;
  torque *= scale;
}

}  // namespace cariesim
