#include "cariesim/device/safety.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "cariesim/device/input_guard.hpp"

namespace cariesim {

namespace {

// The process-wide stop (request_force_stop); lock-free, so a signal handler may set it.
std::atomic<bool> g_force_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free);

// A negative value becomes 0 (the safe side), a non-finite one the fallback.
double sane(double value, double fallback) { return std::isfinite(value) ? std::max(value, 0.0) : fallback; }

// The safety flag of each input fault the guard reports.
uint32_t safety_flags_of(uint32_t input_faults) {
  uint32_t flags = 0;
  if ((input_faults & kInputInvalid) != 0) flags |= kSafetyInvalidInput;
  if ((input_faults & kInputNonFinite) != 0) flags |= kSafetyNonFinite;
  if ((input_faults & kInputStale) != 0) flags |= kSafetyStale;
  if ((input_faults & kInputJump) != 0) flags |= kSafetyJump;
  return flags;
}

}  // namespace

void request_force_stop() noexcept { g_force_stop.store(true, std::memory_order_release); }
bool force_stop_requested() noexcept { return g_force_stop.load(std::memory_order_acquire); }
void clear_force_stop() noexcept { g_force_stop.store(false, std::memory_order_release); }

ForceSafety::ForceSafety(const SafetyParams& params) : params_(params) {
  const SafetyParams defaults;
  params_.ramp_time = sane(params.ramp_time, defaults.ramp_time);
  set_force_scale(params.force_scale);
}

void ForceSafety::set_force_scale(double scale) {
  params_.force_scale = std::isfinite(scale) ? std::clamp(scale, 0.0, 1.0) : 0.0;
}

void ForceSafety::reset() {
  ramp_start_ = -1.0;
  flags_ = 0;
}

void ForceSafety::filter(Vec3& force, Vec3& torque, uint32_t input_faults, double now) {
  // Faults: the guard's verdict on the reading, a non-finite wrench or time.
  flags_ = safety_flags_of(input_faults);
  if (!force.allFinite() || !torque.allFinite() || !std::isfinite(now)) flags_ |= kSafetyNonFinite;
  if (force_stop_requested()) flags_ |= kSafetyStopped;
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
