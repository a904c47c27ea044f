#include "cariesim/device/devices.hpp"

#include <cmath>
#include <utility>

#include "cariesim/common/error.hpp"

namespace cariesim {

DeviceInfo NullDevice::info() const {
  DeviceInfo info;
  info.name = "null";
  info.description = "holds the tool still";
  info.limits = limits_;
  info.renders_force = false;
  return info;
}

DeviceState NullDevice::read(double now) {
  DeviceState s;
  s.pose = pose_;
  s.stamp = now;
  s.sequence = ++sequence_;
  s.valid = true;
  return s;
}

void NullDevice::write(const Vec3& /*force*/, const Vec3& /*torque*/) {}

ScriptedDevice::ScriptedDevice(Trajectory trajectory, bool loop, std::string description,
                               const DeviceLimits& limits)
    : trajectory_(std::move(trajectory)),
      cursor_(trajectory_),
      loop_(loop),
      description_(std::move(description)),
      limits_(limits) {
  if (trajectory_.empty()) throw Error("scripted device " + description_ + ": the trajectory is empty");
  previous_pose_ = trajectory_.pose.front();
}

DeviceInfo ScriptedDevice::info() const {
  DeviceInfo info;
  info.name = "scripted";
  info.description = description_ + (loop_ ? " (loop)" : "");
  info.limits = limits_;
  info.renders_force = false;
  return info;
}

void ScriptedDevice::start() {
  started_ = false;
  finished_ = false;
  cursor_ = TrajectoryCursor(trajectory_);
}

DeviceState ScriptedDevice::read(double now) {
  DeviceState s;
  s.stamp = now;
  s.sequence = ++sequence_;
  if (!started_) {
    started_ = true;
    origin_ = now;
    previous_now_ = now;
  }
  // Trajectory time on the servo clock under the playback rule (common/trajectory.hpp): looping
  // wraps it, otherwise the end holds.
  const double duration = trajectory_.end() - trajectory_.start();
  const double elapsed = now - origin_;
  if (!loop_ && elapsed > duration) finished_ = true;
  s.pose = finished_ ? trajectory_.pose.back()
                     : cursor_.at(trajectory_.start() + playback_offset(elapsed, duration, loop_));
  s.valid = !finished_;

  // Velocities: backward differences between consecutive readings.
  const double dt = now - previous_now_;
  if (dt > 0.0 && s.valid) {
    s.velocity = (s.pose.p - previous_pose_.p) / dt;
    s.angular_velocity = rotation_vector(s.pose.q * previous_pose_.q.conjugate()) / dt;
  }
  previous_now_ = now;
  previous_pose_ = s.pose;
  return s;
}

void ScriptedDevice::write(const Vec3& force, const Vec3& /*torque*/) { force_ = force; }

}  // namespace cariesim
