#include "cariesim/device/haptic_device.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {

// N·mm, the torque limit a 3-DoF-force device announces: it limits no torque, it drops it (the
// largest limit the servo loop accepts, so the scene's stays in force).
constexpr double kNoTorqueLimit = 1e5;
// N/mm, announced when the SDK states no stiffness (the scene's stays in force).
constexpr double kNoStiffnessLimit = 1e6;
// mm, the workspace announced: with the clutch the hand reaches the whole scene.
constexpr double kReach = 1e4;
// How often the watcher asks for calibration again while the operator must act.
// s, the longest time a force is taken to be held for by the continuous-force limit (a servo cycle
// is shorter; a gap between writes, e.g. a pause, is not a load).
constexpr double kThermalStep = 0.01;
constexpr auto kCalibrationPoll = std::chrono::milliseconds(200);

}  // namespace

std::string HapticStatus::rendering() const {
  if (hardware.dof_out >= 6) return "6-DoF: force and torque";
  return "3-DoF force: the torque (the shank's posture cue) is not rendered";
}

HapticDevice::HapticDevice(std::unique_ptr<HardwareDevice> hardware, DeviceProfile profile, const Pose& home)
    : hardware_(std::move(hardware)), profile_(std::move(profile)), home_(home) {
  if (!hardware_) throw Error("haptic device: no hardware device");
}

HapticDevice::~HapticDevice() { stop(); }

DeviceInfo HapticDevice::info() const {
  DeviceInfo out;
  out.name = info_.backend.empty() ? "hardware" : info_.backend;
  out.description = info_.model + (info_.serial.empty() ? "" : " #" + info_.serial) +
                    (info_.sdk.empty() ? "" : " (" + info_.sdk + ")") + "; profile " + profile_.origin;
  out.limits = limits_;
  out.renders_force = true;
  return out;
}

namespace {

// What a device can render, in the scene: its peak force; its stiffness over the scale (the hand
// feels s times the scene's stiffness); its torque when it renders torque (a 3-DoF-force device
// announces no torque limit: it drops the torque, and the scene's limit stays in force).
DeviceLimits scene_limits(const HardwareInfo& info, double scale) {
  DeviceLimits out;
  if (info.max_force > 0.0) out.max_force = info.max_force;
  out.max_stiffness = info.max_stiffness > 0.0 ? info.max_stiffness / scale : kNoStiffnessLimit;
  out.max_torque = info.dof_out >= 6 && info.max_torque > 0.0 ? info.max_torque : kNoTorqueLimit;
  out.position_resolution = 0.0;
  out.workspace = Eigen::AlignedBox3d(Vec3::Constant(-kReach), Vec3::Constant(kReach));
  return out;
}

}  // namespace

void HapticDevice::start() {
  if (watching_.load() || ready_.load()) return;
  hardware_->open();
  info_ = hardware_->info();
  limits_ = scene_limits(info_, profile_.scale);

  // The mapping: the profile's rotation after the backend's axes; the workspace centre (scaled) at
  // the profile's translation, by default the tool home; the stylus's rest orientation at the home's.
  map_q_ = (profile_.rotation * info_.axes).normalized();
  const Vec3 centre = info_.workspace.isEmpty() ? Vec3::Zero() : Vec3(info_.workspace.center());
  const Vec3 target = profile_.translation.value_or(home_.p);
  map_t_ = target - map_q_ * (profile_.scale * centre) - home_.q * profile_.stylus_offset;
  stylus_q_ = ((map_q_ * info_.rest_orientation).inverse() * home_.q).normalized();
  clutch_offset_ = Vec3::Zero();
  clutch_held_ = false;
  limits_sent_ = false;
  enabled_ = false;
  ramp_start_ = -1.0;
  force_was_on_.store(false);
  mean_square_ = 0.0;
  last_square_ = 0.0;
  last_write_ = -1.0;
  last_pose_ = home_;

  // Calibration (homing): ready now, or a watcher asks again until the operator has acted.
  const Calibration calibration = hardware_->calibrate();
  {
    const std::lock_guard lock(calibration_mutex_);
    calibration_ = calibration;
  }
  if (calibration.readiness == Readiness::Failed) {
    hardware_->close();
    throw Error(info_.backend + " (" + info_.model + "): calibration failed: " + calibration.message);
  }
  if (calibration.readiness == Readiness::Ready) {
    ready_.store(true);
    return;
  }
  watching_.store(true);
  watcher_ = std::thread([this] { watch_calibration(); });
}

void HapticDevice::watch_calibration() {
  while (watching_.load()) {
    std::this_thread::sleep_for(kCalibrationPoll);
    if (!watching_.load()) break;
    const Calibration calibration = hardware_->calibrate();
    {
      const std::lock_guard lock(calibration_mutex_);
      calibration_ = calibration;
    }
    if (calibration.readiness == Readiness::Ready) {
      ready_.store(true);
      break;
    }
  }
}

void HapticDevice::stop() {
  watching_.store(false);
  if (watcher_.joinable()) watcher_.join();
  if (enabled_) hardware_->write(Vec3::Zero(), Vec3::Zero());
  hardware_->enable_force(false);
  enabled_ = false;
  force_on_.store(false);
  ready_.store(false);
  hardware_->close();
}

DeviceState HapticDevice::read(double now) {
  const HardwareReading r = hardware_->read();
  now_ = now;
  faults_ = r.faults;
  last_faults_.store(r.faults, std::memory_order_relaxed);
  const double s = profile_.scale;

  // The hand's tool pose (the tip), then the clutch: held, the tool stays where it stood and the
  // hand moves freely; released, the offset takes up the hand's move (CHAI3D's re-indexing).
  const Quat q = info_.dof_in >= 6 ? (map_q_ * r.pose.q * stylus_q_).normalized()
                                   : profile_.fixed_orientation.value_or(home_.q);
  const Vec3 hand = map_q_ * (s * r.pose.p) + map_t_ + q * profile_.stylus_offset;
  const uint32_t actions = profile_actions(profile_, r.buttons);
  const bool clutch = (actions & kActionClutch) != 0 && r.valid;
  if (clutch && !clutch_held_) clutch_pose_ = last_pose_;
  if (!clutch && clutch_held_) {
    clutch_offset_ = clutch_pose_.p - hand;
    ramp_start_ = now;  // the force ramps in again after a re-index
  }
  clutch_held_ = clutch;
  clutched_.store(clutch, std::memory_order_relaxed);

  DeviceState out;
  out.pose.q = q;
  out.pose.p = clutch ? clutch_pose_.p : Vec3(hand + clutch_offset_);
  out.velocity = clutch ? Vec3::Zero() : Vec3(map_q_ * (s * r.velocity));
  out.angular_velocity = info_.dof_in >= 6 ? Vec3(map_q_ * r.angular_velocity) : Vec3::Zero();
  out.buttons = r.buttons;
  out.actions = actions;
  out.stamp = now;
  out.sequence = ++sequence_;
  out.valid = r.valid && r.faults == 0;
  reading_valid_ = out.valid;
  if (out.valid) last_pose_ = out.pose;
  return out;
}

void HapticDevice::write(const Vec3& force, const Vec3& torque) {
  // A fault, an invalid reading or the clutch: no force this cycle. A device lost (or needing
  // calibration again after it came back) also has its force switch turned off: the backend reopens
  // it with force off, and force returns only through the gate and the ramp below.
  if (!reading_valid_ || clutch_held_) {  // (a reading with a fault is never valid)
    hardware_->write(Vec3::Zero(), Vec3::Zero());
    if (enabled_ && (faults_ & (kHardwareLost | kHardwareNotCalibrated)) != 0) {
      hardware_->enable_force(false);
      enabled_ = false;
      force_on_.store(false, std::memory_order_relaxed);
    }
    return;
  }
  // The force switch goes on once the device is ready and the tool out of contact (a small force).
  if (!enabled_) {
    if (!ready_.load(std::memory_order_acquire) || !(force.norm() < profile_.force_enable_below)) {
      hardware_->write(Vec3::Zero(), Vec3::Zero());
      return;
    }
    hardware_->enable_force(true);
    enabled_ = true;
    force_on_.store(true, std::memory_order_relaxed);
    force_was_on_.store(true, std::memory_order_relaxed);
    ramp_start_ = now_;
  }

  // Ramp in after enabling and after a clutch.
  const double ramp = profile_.ramp_time > 0.0 && ramp_start_ >= 0.0
                          ? std::clamp((now_ - ramp_start_) / profile_.ramp_time, 0.0, 1.0)
                          : 1.0;
  Vec3 f = ramp * force;
  if (!f.allFinite()) f.setZero();
  if (info_.max_force > 0.0 && f.norm() > info_.max_force) f *= info_.max_force / f.norm();

  // The continuous (thermal) limit: a first-order mean of the squared force over the time constant
  // tau. The force rendered since the last write enters the mean, m += a (|f_last|² - m) with
  // a = 1 - exp(-dt / tau); the new force is then scaled down if, held for the same time (at most
  // kThermalStep), it would take the mean above continuous_force². A peak passes while the mean is
  // low; a sustained load settles at the continuous force.
  const double dt = last_write_ >= 0.0 ? std::max(0.0, now_ - last_write_) : 0.0;
  last_write_ = now_;
  if (info_.continuous_force > 0.0) {
    const double tau = profile_.continuous_time_constant;
    mean_square_ += (1.0 - std::exp(-dt / tau)) * (last_square_ - mean_square_);
    const double limit2 = info_.continuous_force * info_.continuous_force;
    const double alpha = 1.0 - std::exp(-std::clamp(dt, 1e-4, kThermalStep) / tau);
    const double allowed2 = std::max(0.0, mean_square_ + (limit2 - mean_square_) / alpha);
    if (f.squaredNorm() > allowed2) {
      f *= std::sqrt(allowed2 / f.squaredNorm());
      continuous_limited_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  last_square_ = f.squaredNorm();

  // The torque: a 3-DoF-force device drops it (counted); a 6-DoF one gets it about its device point
  // (the tip's torque plus the stylus offset's lever), within its limit.
  Vec3 t = Vec3::Zero();
  if (info_.dof_out >= 6) {
    t = ramp * (torque + (last_pose_.q * profile_.stylus_offset).cross(f));
    if (!t.allFinite()) t.setZero();
    if (info_.max_torque > 0.0 && t.norm() > info_.max_torque) t *= info_.max_torque / t.norm();
  } else if (torque.allFinite() && torque.norm() > 0.0) {
    torque_dropped_.fetch_add(1, std::memory_order_relaxed);
    const double n = torque.norm();
    if (n > torque_dropped_max_.load(std::memory_order_relaxed))
      torque_dropped_max_.store(n, std::memory_order_relaxed);
  }

  // Into the device's frame.
  const Quat to_device = map_q_.inverse();
  hardware_->write(to_device * f, to_device * t);
}

bool HapticDevice::poll_limits(LimitsAnnouncement& out) {
  if (limits_sent_ || info_.backend.empty()) return false;
  limits_sent_ = true;
  out.withdrawn = false;
  out.limits = limits_;
  return true;
}

std::vector<DeviceCounter> HapticDevice::counters() const {
  return {{"torque_dropped", torque_dropped_.load()},
          {"continuous_limited", continuous_limited_.load()},
          {"force_enabled", force_on_.load() ? 1u : 0u}};
}

HapticStatus HapticDevice::status() const {
  HapticStatus out;
  out.hardware = info_;
  {
    const std::lock_guard lock(calibration_mutex_);
    out.calibration = calibration_;
  }
  out.force_enabled = force_on_.load();
  out.force_was_enabled = force_was_on_.load();
  out.clutched = clutched_.load();
  out.faults = last_faults_.load();
  out.torque_dropped = torque_dropped_.load();
  out.torque_dropped_max = torque_dropped_max_.load();
  out.continuous_limited = continuous_limited_.load();
  return out;
}

}  // namespace cariesim
