// The hardware-free devices (null, scripted). The device factory's specs are tested in
// factory_test.cpp.
#include "cariesim/device/devices.hpp"

#include <gtest/gtest.h>

#include "cariesim/common/error.hpp"

namespace cariesim {
namespace {

// A 1 s trajectory: 10 mm along x at constant speed, turning 0.5 rad about z.
Trajectory straight_line() {
  Trajectory tr;
  tr.add(2.0, Pose{Vec3(0, 0, 0), Quat::Identity()});
  tr.add(3.0, Pose{Vec3(10, 0, 0), quat_from_rotation_vector(Vec3(0, 0, 0.5))});
  return tr;
}

TEST(NullDevice, HoldsItsPose) {
  const Pose home{Vec3(1, 2, 3), quat_from_rotation_vector(Vec3(0.1, 0, 0))};
  NullDevice d(home);
  EXPECT_EQ(d.info().name, "null");
  EXPECT_FALSE(d.info().renders_force);
  const DeviceState a = d.read(0.5);
  d.write(Vec3(1, 1, 1), Vec3::Zero());
  const DeviceState b = d.read(0.6);
  for (const DeviceState& s : {a, b}) {
    EXPECT_TRUE(s.valid);
    EXPECT_EQ(s.pose.p, home.p);
    EXPECT_TRUE(s.pose.q.isApprox(home.q));
    EXPECT_TRUE(s.velocity.isZero());
  }
  EXPECT_DOUBLE_EQ(b.stamp, 0.6);
  EXPECT_GT(b.sequence, a.sequence);
}

TEST(ScriptedDevice, FollowsTheTrajectoryOnTheServoClock) {
  ScriptedDevice d(straight_line(), false, "line");
  d.start();
  // The first read is the trajectory's start, whatever the servo time.
  const DeviceState s0 = d.read(100.0);
  EXPECT_TRUE(s0.valid);
  EXPECT_TRUE(s0.pose.p.isZero());
  EXPECT_TRUE(s0.velocity.isZero());
  const DeviceState s1 = d.read(100.25);
  EXPECT_NEAR(s1.pose.p.x(), 2.5, 1e-12);
  EXPECT_NEAR(s1.velocity.x(), 10.0, 1e-9);  // mm/s, finite difference
  EXPECT_NEAR(s1.angular_velocity.z(), 0.5, 1e-9);
  EXPECT_DOUBLE_EQ(s1.stamp, 100.25);
  EXPECT_GT(s1.sequence, s0.sequence);
  const DeviceState s2 = d.read(100.5);
  EXPECT_NEAR(s2.pose.p.x(), 5.0, 1e-12);
  EXPECT_NEAR(rotation_vector(s2.pose.q).z(), 0.25, 1e-12);
  EXPECT_FALSE(d.finished());
}

TEST(ScriptedDevice, EndsInvalidHoldingTheLastPose) {
  ScriptedDevice d(straight_line(), false, "line");
  d.start();
  d.read(0.0);
  EXPECT_TRUE(d.read(1.0).valid);  // the last sample itself
  const DeviceState after = d.read(1.001);
  EXPECT_FALSE(after.valid);
  EXPECT_TRUE(d.finished());
  EXPECT_NEAR(after.pose.p.x(), 10.0, 1e-12);
  EXPECT_TRUE(after.velocity.isZero());
  // start() rewinds.
  d.start();
  EXPECT_TRUE(d.read(7.0).valid);
  EXPECT_NEAR(d.read(7.5).pose.p.x(), 5.0, 1e-12);
}

TEST(ScriptedDevice, LoopsWhenAsked) {
  ScriptedDevice d(straight_line(), true, "line");
  d.start();
  d.read(0.0);
  const DeviceState s = d.read(2.25);  // a quarter into the third pass
  EXPECT_TRUE(s.valid);
  EXPECT_NEAR(s.pose.p.x(), 2.5, 1e-9);
  EXPECT_FALSE(d.finished());
  EXPECT_NE(d.info().description.find("loop"), std::string::npos);
}

TEST(ScriptedDevice, RefusesAnEmptyTrajectory) {
  EXPECT_THROW(ScriptedDevice(Trajectory{}, false, "x"), Error);
}

}  // namespace
}  // namespace cariesim
