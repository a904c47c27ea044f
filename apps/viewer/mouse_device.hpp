#pragma once
/// The mouse device (docs/design.md §5): the UI thread turns drags and the wheel into a target pose
/// (MouseControl) and hands it to the servo thread through a lock-free triple buffer (MouseDevice).
/// The servo thread follows the target at a bounded speed, so a fast drag does not become a jump of
/// centimetres in one servo cycle. A mouse renders no force (DeviceInfo::renders_force is false): the
/// viewer draws the force as an arrow and in the plot instead.

#include <cstdint>

#include "camera.hpp"
#include "cariesim/common/lockfree.hpp"
#include "cariesim/device/device.hpp"

namespace cariesim::viewer {

/// What the UI thread hands to the servo thread.
struct MouseTarget {
  Pose pose;                ///< tool frame in the world (mm)
  uint32_t buttons = 0;     ///< bit i = button i pressed
  uint64_t generation = 0;  ///< a new generation makes the device jump to `pose` instead of moving
};

/// How fast the device follows its target.
struct MouseDeviceParams {
  double max_speed = 150.0;        ///< mm/s, translation of the tool tip
  double max_angular_speed = 4.0;  ///< rad/s
};

class MouseDevice : public Device {
 public:
  /// Starts at `home`; `limits` are the simulator's (the mouse adds none of its own).
  MouseDevice(const Pose& home, const DeviceLimits& limits, const MouseDeviceParams& params = {});
  /// name "mouse", renders_force false.
  [[nodiscard]] DeviceInfo info() const override;
  /// Forgets the servo clock (a restarted loop may begin its clock anew).
  void start() override;
  /// Moves toward the newest target by at most max_speed·dt (servo thread; lock- and allocation-free).
  DeviceState read(double now) override;
  /// Keeps the wrench for the UI's readouts only: a mouse cannot render it.
  void write(const Vec3& force, const Vec3& torque) override;

  /// UI thread: the pose the device moves toward, and the buttons held.
  void set_target(const Pose& pose, uint32_t buttons = 0);
  /// UI thread: the device jumps to `pose` at its next reading (use while the servo loop is stopped,
  /// e.g. when the tool is reset or the scene changes).
  void jump_to(const Pose& pose);

 private:
  DeviceLimits limits_;
  MouseDeviceParams params_;
  TripleBuffer<MouseTarget> targets_;
  MouseTarget ui_target_;  // UI thread's last published target
  // Servo thread only:
  MouseTarget target_;
  Pose current_;
  uint64_t generation_seen_ = 0;
  double last_now_ = 0.0;  // s
  bool clock_started_ = false;
  uint64_t sequence_ = 0;
};

/// Maps mouse gestures to the tool's target pose (UI thread): left-drag moves the tool in the view
/// plane, the wheel moves it in depth, right-drag rotates it about its tip.
class MouseControl {
 public:
  double wheel_step = 0.5;    ///< mm of depth per wheel notch
  double rotate_gain = 0.01;  ///< rad per pixel of right-drag
  Eigen::AlignedBox3d workspace{Vec3(-200, -200, -200), Vec3(200, 200, 200)};  ///< mm, the tip stays inside

  /// Sets the target (e.g. the scene's tool home).
  void reset(const Pose& pose) { target_ = pose; }
  [[nodiscard]] const Pose& target() const { return target_; }
  /// Left-drag by (dx, dy) pixels (x right, y down) in a viewport `height_px` tall: the tip moves in
  /// the plane through it parallel to the screen, following the cursor.
  void drag_move(double dx, double dy, const OrbitCamera& camera, double height_px);
  /// Wheel by `notches` (positive: away from the eye, into the scene), `fine` = a tenth of the step.
  void wheel(double notches, const OrbitCamera& camera, bool fine = false);
  /// Right-drag by (dx, dy) pixels: turns the tool about its tip, horizontal drags about the screen's
  /// up axis, vertical drags about its right axis.
  void drag_rotate(double dx, double dy, const OrbitCamera& camera);

 private:
  void clamp_to_workspace();
  Pose target_;
};

}  // namespace cariesim::viewer
