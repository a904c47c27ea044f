#include "mouse_device.hpp"

#include <algorithm>
#include <cmath>

namespace cariesim::viewer {

MouseDevice::MouseDevice(const Pose& home, const DeviceLimits& limits, const MouseDeviceParams& params)
    : limits_(limits), params_(params) {
  jump_to(home);
}

DeviceInfo MouseDevice::info() const {
  DeviceInfo out;
  out.name = "mouse";
  out.description = "mouse in the viewer: drag to move, wheel for depth, right-drag to rotate";
  out.limits = limits_;
  out.renders_force = false;
  return out;
}

void MouseDevice::start() { clock_started_ = false; }

DeviceState MouseDevice::read(double now) {
  // The servo period since the last reading (0 at the first one).
  const double dt = clock_started_ && now > last_now_ ? now - last_now_ : 0.0;
  last_now_ = now;
  clock_started_ = true;
  targets_.read(target_);
  const Pose before = current_;

  // A new generation jumps; otherwise move toward the target at bounded linear and angular speed.
  if (target_.generation != generation_seen_) {
    generation_seen_ = target_.generation;
    current_ = target_.pose;
  } else {
    const Vec3 to_target = target_.pose.p - current_.p;
    const double max_step = params_.max_speed * dt;
    const double distance = to_target.norm();
    current_.p += distance > max_step ? to_target * (max_step / distance) : to_target;
    const double angle = current_.q.angularDistance(target_.pose.q);
    const double max_turn = params_.max_angular_speed * dt;
    current_.q = angle > max_turn ? current_.q.slerp(max_turn / angle, target_.pose.q) : target_.pose.q;
    current_.q.normalize();
  }

  // The reading: always fresh (a mouse at rest still holds its pose), velocities from this step.
  DeviceState state;
  state.pose = current_;
  state.buttons = target_.buttons;
  state.stamp = now;
  state.sequence = ++sequence_;
  state.valid = true;
  if (dt > 0.0) {
    state.velocity = (current_.p - before.p) / dt;
    state.angular_velocity = rotation_vector(current_.q * before.q.conjugate()) / dt;
  }
  return state;
}

void MouseDevice::write(const Vec3& /*force*/, const Vec3& /*torque*/) {}

void MouseDevice::set_target(const Pose& pose, uint32_t buttons) {
  ui_target_.pose = pose;
  ui_target_.buttons = buttons;
  targets_.write(ui_target_);
}

void MouseDevice::jump_to(const Pose& pose) {
  ui_target_.pose = pose;
  ++ui_target_.generation;
  targets_.write(ui_target_);
}

void MouseControl::drag_move(double dx, double dy, const OrbitCamera& camera, double height_px) {
  // Scale pixels to millimetres at the tip's depth so the tip stays under the cursor.
  const double depth = (target_.p - camera.eye()).dot(camera.forward());
  const double mm = camera.mm_per_pixel(depth, height_px);
  target_.p += (dx * camera.right() - dy * camera.up()) * mm;
  clamp_to_workspace();
}

void MouseControl::wheel(double notches, const OrbitCamera& camera, bool fine) {
  target_.p += camera.forward() * (notches * wheel_step * (fine ? 0.1 : 1.0));
  clamp_to_workspace();
}

void MouseControl::drag_rotate(double dx, double dy, const OrbitCamera& camera) {
  // World-frame rotations about axes through the tip (the tool frame's origin).
  const Quat turn = Quat(Eigen::AngleAxisd(dx * rotate_gain, camera.up())) *
                    Quat(Eigen::AngleAxisd(dy * rotate_gain, camera.right()));
  target_.q = (turn * target_.q).normalized();
}

void MouseControl::clamp_to_workspace() {
  target_.p = target_.p.cwiseMax(workspace.min()).cwiseMin(workspace.max());
}

}  // namespace cariesim::viewer
