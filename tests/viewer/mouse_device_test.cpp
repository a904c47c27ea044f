// The mouse device (apps/viewer/mouse_device.cpp): the lock-free hand-off from the UI thread, the
// bounded following speed, jumps, and the gesture mapping of MouseControl.
#include "viewer/mouse_device.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

namespace {

using cariesim::DeviceLimits;
using cariesim::DeviceState;
using cariesim::Pose;
using cariesim::Quat;
using cariesim::Vec3;
using cariesim::viewer::MouseControl;
using cariesim::viewer::MouseDevice;
using cariesim::viewer::MouseDeviceParams;
using cariesim::viewer::OrbitCamera;

Pose at(double x, double y, double z) {
  Pose p;
  p.p = Vec3(x, y, z);
  return p;
}

// The first reading is the home pose; the device says it renders no force.
TEST(MouseDevice, StartsAtHomeAndRendersNoForce) {
  MouseDevice device(at(1, 2, 3), DeviceLimits{});
  EXPECT_EQ(device.info().name, "mouse");
  EXPECT_FALSE(device.info().renders_force);
  device.start();
  const DeviceState s = device.read(0.0);
  EXPECT_TRUE(s.valid);
  EXPECT_TRUE(s.pose.p.isApprox(Vec3(1, 2, 3)));
  EXPECT_EQ(s.sequence, 1u);
  EXPECT_DOUBLE_EQ(s.stamp, 0.0);
}

// A far target is approached at no more than max_speed, and reached in the end; the velocity is
// the step over dt.
TEST(MouseDevice, FollowsTheTargetAtBoundedSpeed) {
  MouseDeviceParams params;
  params.max_speed = 100.0;  // mm/s: 0.1 mm per 1 ms cycle
  MouseDevice device(at(0, 0, 0), DeviceLimits{}, params);
  device.start();
  (void)device.read(0.0);
  device.set_target(at(10, 0, 0));
  const DeviceState s1 = device.read(0.001);
  EXPECT_NEAR(s1.pose.p.x(), 0.1, 1e-9);
  EXPECT_NEAR(s1.velocity.x(), 100.0, 1e-6);
  double previous = s1.pose.p.x();
  for (int i = 2; i <= 200; ++i) {
    const double x = device.read(0.001 * i).pose.p.x();
    EXPECT_LE(x - previous, 0.1 + 1e-9);
    previous = x;
  }
  EXPECT_NEAR(previous, 10.0, 1e-9);
  EXPECT_NEAR(device.read(0.201).velocity.norm(), 0.0, 1e-9);
}

// Rotation is bounded too: a half turn at 4 rad/s takes about 0.79 s.
TEST(MouseDevice, TurnsAtBoundedAngularSpeed) {
  MouseDevice device(at(0, 0, 0), DeviceLimits{});
  device.start();
  (void)device.read(0.0);
  Pose target = at(0, 0, 0);
  target.q = Quat(Eigen::AngleAxisd(3.0, Vec3::UnitX()));
  device.set_target(target);
  const DeviceState s = device.read(0.01);
  EXPECT_NEAR(s.pose.q.angularDistance(Quat::Identity()), 0.04, 1e-9);
  EXPECT_NEAR(s.angular_velocity.norm(), 4.0, 1e-6);
  DeviceState last;
  for (int i = 2; i <= 100; ++i) last = device.read(0.01 * i);
  EXPECT_NEAR(last.pose.q.angularDistance(target.q), 0.0, 1e-9);
}

// jump_to moves at once (a reset); targets after it are followed at bounded speed again.
TEST(MouseDevice, JumpIsImmediate) {
  MouseDevice device(at(0, 0, 0), DeviceLimits{});
  device.start();
  (void)device.read(0.0);
  device.jump_to(at(50, 0, 0));
  EXPECT_NEAR(device.read(0.001).pose.p.x(), 50.0, 1e-9);
  device.set_target(at(50, 1, 0));
  const DeviceState s = device.read(0.002);
  EXPECT_NEAR(s.pose.p.x(), 50.0, 1e-9);
  EXPECT_NEAR(s.pose.p.y(), 0.15, 1e-9) << "150 mm/s for 1 ms";
}

// One thread publishing targets and one reading never sees a torn or non-finite pose.
TEST(MouseDevice, HandOffAcrossThreads) {
  MouseDevice device(at(0, 0, 0), DeviceLimits{});
  device.start();
  std::atomic<bool> done{false};
  std::thread ui([&] {
    for (int i = 0; i < 20000; ++i) device.set_target(at(i % 7, -(i % 5), 0.5 * (i % 3)));
    done = true;
  });
  int bad = 0;
  uint64_t sequence = 0;
  for (int i = 1; !done || i < 1000; ++i) {
    const DeviceState s = device.read(0.001 * i);
    if (!s.pose.finite() || s.sequence <= sequence) ++bad;
    sequence = s.sequence;
  }
  ui.join();
  EXPECT_EQ(bad, 0);
}

// Left-drag: the tip stays under the cursor (it moves by the drag in pixels, in the view plane).
TEST(MouseControl, DragMovesTheTipWithTheCursor) {
  OrbitCamera camera;
  camera.target = Vec3(0, 0, 0);
  camera.distance = 100.0;
  camera.yaw = 0.3;
  camera.pitch = 0.5;
  MouseControl control;
  control.reset(at(2, 3, 1));
  Eigen::Vector2d before, after;
  ASSERT_TRUE(camera.project(control.target().p, 1200.0, 800.0, before));
  const double depth_before = (control.target().p - camera.eye()).dot(camera.forward());
  control.drag_move(40.0, -25.0, camera, 800.0);
  ASSERT_TRUE(camera.project(control.target().p, 1200.0, 800.0, after));
  EXPECT_NEAR(after.x() - before.x(), 40.0, 1e-6);
  EXPECT_NEAR(after.y() - before.y(), -25.0, 1e-6);
  EXPECT_NEAR((control.target().p - camera.eye()).dot(camera.forward()), depth_before, 1e-9);
}

// The wheel moves along the view direction (away from the eye for positive notches); shift is finer.
TEST(MouseControl, WheelMovesInDepth) {
  OrbitCamera camera;
  MouseControl control;
  control.reset(at(0, 0, 0));
  control.wheel(2.0, camera);
  EXPECT_TRUE(control.target().p.isApprox(camera.forward() * 1.0, 1e-12));
  control.wheel(-10.0, camera, true);
  EXPECT_NEAR(control.target().p.norm(), 0.5, 1e-12);
}

// Right-drag turns the tool about its tip: the position stays, the rotation follows the drag.
TEST(MouseControl, RightDragTurnsAboutTheTip) {
  OrbitCamera camera;
  MouseControl control;
  control.reset(at(4, 5, 6));
  control.drag_rotate(100.0, 0.0, camera);
  EXPECT_TRUE(control.target().p.isApprox(Vec3(4, 5, 6)));
  EXPECT_NEAR(control.target().q.angularDistance(Quat::Identity()), 1.0, 1e-9);
  // The rotation axis is the screen's up axis: it is left unchanged by the turn.
  EXPECT_TRUE((control.target().q * camera.up()).isApprox(camera.up(), 1e-9));
}

// The target stays inside the workspace.
TEST(MouseControl, ClampsToTheWorkspace) {
  OrbitCamera camera;
  MouseControl control;
  control.workspace = Eigen::AlignedBox3d(Vec3(-10, -10, -10), Vec3(10, 10, 10));
  control.reset(at(0, 0, 0));
  control.wheel(1000.0, camera);
  EXPECT_TRUE(control.workspace.contains(control.target().p));
  EXPECT_NEAR((control.target().p.cwiseAbs() - Vec3(10, 10, 10)).cwiseAbs().minCoeff(), 0.0, 1e-9);
}

}  // namespace
