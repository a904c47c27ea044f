// HapticDevice: the mapping, clutch, buttons, force enabling and limits every hardware backend shares,
// over a hardware device the test moves by hand (the SDK stand-ins test the backends themselves).
#include "cariesim/device/haptic_device.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <memory>
#include <numbers>
#include <string>

#include "cariesim/common/error.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

// A hand the test moves: the last reading it gives and the last wrench it was sent (device frame).
struct Hand {
  HardwareInfo info;
  HardwareReading reading;
  Readiness readiness = Readiness::Ready;
  Vec3 force = Vec3::Constant(-1.0);
  Vec3 torque = Vec3::Constant(-1.0);
  bool force_enabled = false;
  bool open = false;
  int calibrations = 0;
};

class HandDevice : public HardwareDevice {
 public:
  explicit HandDevice(Hand& hand) : hand_(hand) {}
  void open() override { hand_.open = true; }
  void close() override {
    hand_.force_enabled = false;
    hand_.open = false;
  }
  [[nodiscard]] HardwareInfo info() const override { return hand_.info; }
  Calibration calibrate() override {
    ++hand_.calibrations;
    return {hand_.readiness,
            hand_.readiness == Readiness::Ready ? "calibrated" : "put the stylus in the inkwell"};
  }
  HardwareReading read() override { return hand_.reading; }
  void write(const Vec3& force, const Vec3& torque) override {
    hand_.force = force;
    hand_.torque = torque;
  }
  void enable_force(bool on) override { hand_.force_enabled = on; }

 private:
  Hand& hand_;
};

// OpenHaptics' axes in the operator frame: x right, y up, z toward the user.
Quat touch_axes() {
  Mat3 m;
  m.col(0) = Vec3(1, 0, 0);
  m.col(1) = Vec3(0, 0, 1);
  m.col(2) = Vec3(0, -1, 0);
  return Quat(m);
}

Hand touch_hand() {
  Hand hand;
  hand.info.backend = "touch";
  hand.info.model = "Touch";
  hand.info.dof_in = 6;
  hand.info.dof_out = 3;
  hand.info.buttons = 2;
  hand.info.max_force = 3.3;
  hand.info.continuous_force = 0.88;
  hand.info.max_stiffness = 1.26;
  hand.info.workspace = Eigen::AlignedBox3d(Vec3(-80, -60, -35), Vec3(80, 60, 35));
  hand.info.axes = touch_axes();
  hand.reading.valid = true;
  return hand;
}

Pose home() {
  Pose pose;
  pose.p = Vec3(1.0, 2.0, 12.0);
  pose.q = Quat(Eigen::AngleAxisd(-0.4, Vec3::UnitY()));
  return pose;
}

TEST(HapticDevice, TheWorkspaceCentreAtRestIsTheToolHome) {
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  const DeviceState state = device.read(0.0);
  EXPECT_TRUE(state.valid);
  EXPECT_LT((state.pose.p - home().p).norm(), 1e-9);
  EXPECT_LT(state.pose.q.angularDistance(home().q), 1e-9);
}

TEST(HapticDevice, TheDevicesAxesMapOntoTheScene) {
  // A Touch's +y (up) is the scene's +z, its +z (toward the user) the scene's -y, at half scale.
  Hand hand = touch_hand();
  DeviceProfile profile;
  profile.scale = 0.5;
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, home());
  device.start();
  hand.reading.pose.p = Vec3(0, 10, 20);
  const DeviceState state = device.read(0.0);
  EXPECT_LT((state.pose.p - (home().p + Vec3(0, -10, 5))).norm(), 1e-9);
  // The force comes back through the inverse: the scene's +z is the Touch's +y.
  device.write(Vec3(0, 0, 0.1), Vec3::Zero());  // small: the force switch goes on
  device.read(10.0);
  device.write(Vec3(0, 0, 2.0), Vec3::Zero());
  EXPECT_TRUE(hand.force_enabled);
  EXPECT_LT((hand.force - Vec3(0, 2.0, 0)).norm(), 1e-9);
}

TEST(HapticDevice, TurningTheStylusTurnsTheToolInTheScene) {
  // A quarter turn about the Touch's y axis (up) is a quarter turn about the scene's z.
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  hand.reading.pose.q = Quat(Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitY()));
  const DeviceState state = device.read(0.0);
  const Quat expected = Quat(Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ())) * home().q;
  EXPECT_LT(state.pose.q.angularDistance(expected), 1e-9);
}

TEST(HapticDevice, TheClutchHoldsTheToolAndReleasesWithoutAJumpOrAForceStep) {
  Hand hand = touch_hand();
  DeviceProfile profile;
  profile.ramp_time = 0.5;
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, home());
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  const Vec3 before = device.read(1.0).pose.p;
  device.write(Vec3(0, 0, 1.0), Vec3::Zero());
  ASSERT_GT(hand.force.norm(), 0.5);

  // Held (button 0): the hand moves 30 mm right, the tool stays and no force is rendered.
  hand.reading.buttons = 1u;
  hand.reading.pose.p = Vec3(30, 0, 0);
  const DeviceState held = device.read(1.001);
  EXPECT_NE(held.actions & kActionClutch, 0u);
  EXPECT_LT((held.pose.p - before).norm(), 1e-9);
  device.write(Vec3(0, 0, 1.0), Vec3::Zero());
  EXPECT_EQ(hand.force, Vec3::Zero());

  // Released: the tool goes on from where it stood, then follows the hand's moves.
  hand.reading.buttons = 0;
  const DeviceState released = device.read(1.002);
  EXPECT_LT((released.pose.p - before).norm(), 1e-9);
  device.write(Vec3(0, 0, 1.0), Vec3::Zero());
  EXPECT_LT(hand.force.norm(), 0.01);  // ramping in again from zero
  hand.reading.pose.p = Vec3(35, 0, 0);
  EXPECT_LT((device.read(1.003).pose.p - (before + Vec3(5, 0, 0))).norm(), 1e-9);
  device.read(2.0);
  device.write(Vec3(0, 0, 1.0), Vec3::Zero());
  EXPECT_NEAR(hand.force.norm(), 1.0, 1e-9);
}

TEST(HapticDevice, ButtonsBecomeTheProfilesActions) {
  Hand hand = touch_hand();
  const DeviceProfile profile =
      parse_device_profile("buttons: {0: mark_severe, 1: end_case, 3: clutch}\n", "test.yaml");
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, home());
  device.start();
  hand.reading.buttons = 0b011;
  EXPECT_EQ(device.read(0.0).actions, kActionMarkSevere | kActionEndCase);
  hand.reading.buttons = 0b100;
  EXPECT_EQ(device.read(0.001).actions, 0u);
}

TEST(HapticDevice, NoForceBeforeCalibrationAndUntilTheForceIsSmall) {
  Hand hand = touch_hand();
  hand.readiness = Readiness::NeedsOperator;
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  EXPECT_EQ(device.status().calibration.message, "put the stylus in the inkwell");
  device.read(0.0);
  device.write(Vec3(0, 0, 0.1), Vec3::Zero());
  EXPECT_FALSE(hand.force_enabled);
  EXPECT_EQ(hand.force, Vec3::Zero());

  // The operator calibrates; the watcher sees it. A large force (in contact) still waits.
  hand.readiness = Readiness::Ready;
  for (int i = 0; i < 100 && !device.status().calibration.message.starts_with("calibrated"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(device.status().calibration.readiness, Readiness::Ready);
  device.read(1.0);
  device.write(Vec3(0, 0, 2.0), Vec3::Zero());
  EXPECT_FALSE(hand.force_enabled);
  device.write(Vec3(0, 0, 0.2), Vec3::Zero());
  EXPECT_TRUE(hand.force_enabled);
  EXPECT_TRUE(device.status().force_enabled);
}

TEST(HapticDevice, AFaultZeroesTheForceInTheSameCycle) {
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  device.read(5.0);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  ASSERT_GT(hand.force.norm(), 0.5);
  hand.reading.faults = kHardwareOverheat;
  const DeviceState state = device.read(5.001);
  EXPECT_FALSE(state.valid);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  EXPECT_EQ(hand.force, Vec3::Zero());
  EXPECT_EQ(describe_hardware_faults(device.status().faults), "motors too warm");
}

TEST(HapticDevice, ADeviceLostAndBackReenablesForceOnlyThroughTheGateAndTheRamp) {
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  device.read(5.0);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  ASSERT_TRUE(hand.force_enabled);
  ASSERT_GT(hand.force.norm(), 0.5);

  // Unplugged: zero force and the force switch off in the same cycle; the fault stays shown.
  hand.reading.valid = false;
  hand.reading.faults = kHardwareLost;
  EXPECT_FALSE(device.read(5.001).valid);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  EXPECT_EQ(hand.force, Vec3::Zero());
  EXPECT_FALSE(hand.force_enabled);
  EXPECT_FALSE(device.status().force_enabled);
  EXPECT_EQ(device.status().faults, static_cast<uint32_t>(kHardwareLost));

  // Back (the backend reopened it, force off): a large force waits for the gate.
  hand.reading.valid = true;
  hand.reading.faults = 0;
  EXPECT_TRUE(device.read(6.0).valid);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  EXPECT_FALSE(hand.force_enabled);
  EXPECT_EQ(hand.force, Vec3::Zero());
  EXPECT_EQ(device.status().faults, 0u);
  // A small force passes the gate; the force ramps in from zero over ramp_time.
  device.read(6.001);
  device.write(Vec3(0.2, 0, 0), Vec3::Zero());
  EXPECT_TRUE(hand.force_enabled);
  EXPECT_LT(hand.force.norm(), 0.01);
  device.read(6.001 + 0.25);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  EXPECT_NEAR(hand.force.norm(), 0.5, 0.01);
  device.read(6.001 + 1.0);
  device.write(Vec3(1, 0, 0), Vec3::Zero());
  EXPECT_NEAR(hand.force.norm(), 1.0, 1e-9);
}

TEST(HapticDevice, SustainedForceIsHeldToTheContinuousLimit) {
  Hand hand = touch_hand();  // 3.3 N peak, 0.88 N continuous
  DeviceProfile profile;
  profile.continuous_time_constant = 1.0;
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, home());
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  double t = 1.0;
  device.read(t);
  device.write(Vec3(3.0, 0, 0), Vec3::Zero());
  EXPECT_NEAR(hand.force.norm(), 3.0, 1e-9);  // a peak passes
  double mean_square = 0.0;
  for (int i = 0; i < 10000; ++i) {  // 10 s at 1 kHz, 10 time constants
    t += 0.001;
    device.read(t);
    device.write(Vec3(3.0, 0, 0), Vec3::Zero());
    mean_square += hand.force.squaredNorm();
  }
  EXPECT_LT(hand.force.norm(), 0.88 * 1.05);
  EXPECT_LT(std::sqrt(mean_square / 10000), 1.5);
  EXPECT_GT(device.status().continuous_limited, 0u);
}

TEST(HapticDevice, AThreeDofForceDeviceDropsTheTorqueAndCountsIt) {
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  device.read(5.0);
  device.write(Vec3(0, 0, 1), Vec3(0, 40, 0));
  EXPECT_EQ(hand.torque, Vec3::Zero());
  EXPECT_EQ(device.status().torque_dropped, 1u);
  EXPECT_DOUBLE_EQ(device.status().torque_dropped_max, 40.0);
  EXPECT_NE(device.status().rendering().find("not rendered"), std::string::npos);
}

TEST(HapticDevice, ASixDofDeviceGetsTheTorqueAboutItsPointWithinItsLimit) {
  Hand hand = touch_hand();
  hand.info.dof_out = 6;
  hand.info.max_torque = 100.0;
  hand.info.max_force = 22.0;
  hand.info.continuous_force = 0.0;
  hand.info.axes = Quat::Identity();
  DeviceProfile profile;
  profile.stylus_offset = Vec3(0, 0, -20);  // the tip 20 mm below the device point, tool frame
  const Pose identity_home;
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, identity_home);
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  device.read(5.0);
  // 1 N along x at the tip: about the device point, 20 mm above, a torque of 20 N·mm about -y.
  device.write(Vec3(1, 0, 0), Vec3(0, 0, 5));
  EXPECT_LT((hand.torque - Vec3(0, -20, 5)).norm(), 1e-9);
  device.write(Vec3::Zero(), Vec3(0, 0, 500));
  EXPECT_NEAR(hand.torque.norm(), 100.0, 1e-9);
}

TEST(HapticDevice, AThreeDofInputDeviceHoldsTheProfilesOrientation) {
  Hand hand = touch_hand();
  hand.info.dof_in = 3;
  DeviceProfile profile;
  profile.fixed_orientation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitX()));
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, home());
  device.start();
  hand.reading.pose.q = Quat(Eigen::AngleAxisd(1.0, Vec3::UnitY()));
  EXPECT_LT(device.read(0.0).pose.q.angularDistance(*profile.fixed_orientation), 1e-12);
}

TEST(HapticDevice, ItAnnouncesItsLimitsOnceWithTheStiffnessOverTheScale) {
  Hand hand = touch_hand();
  DeviceProfile profile;
  profile.scale = 2.0;
  HapticDevice device(std::make_unique<HandDevice>(hand), profile, home());
  device.start();
  LimitsAnnouncement news;
  ASSERT_TRUE(device.poll_limits(news));
  EXPECT_FALSE(news.withdrawn);
  EXPECT_DOUBLE_EQ(news.limits.max_force, 3.3);
  EXPECT_DOUBLE_EQ(news.limits.max_stiffness, 0.63);
  EXPECT_FALSE(device.poll_limits(news));
}

TEST(HapticDevice, StopSwitchesTheForceOffAndClosesTheDevice) {
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  device.read(0.0);
  device.write(Vec3::Zero(), Vec3::Zero());
  ASSERT_TRUE(hand.force_enabled);
  device.stop();
  EXPECT_FALSE(hand.force_enabled);
  EXPECT_FALSE(hand.open);
}

TEST(HapticDevice, AFailedCalibrationRefusesToStart) {
  Hand hand = touch_hand();
  hand.readiness = Readiness::Failed;
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  EXPECT_THROW(device.start(), Error);
  EXPECT_FALSE(hand.open);
}

TEST(HapticDevice, ReadAndWriteAllocateNothing) {
  Hand hand = touch_hand();
  HapticDevice device(std::make_unique<HandDevice>(hand), DeviceProfile{}, home());
  device.start();
  LimitsAnnouncement news;
  const std::size_t before = test::allocation_count();
  double t = 0.0;
  for (int i = 0; i < 1000; ++i, t += 0.001) {
    hand.reading.buttons = (i / 100) % 2;  // clutch on and off
    device.poll_limits(news);
    device.read(t);
    device.write(Vec3(0.5, 0, 0), Vec3(0, 1, 0));
  }
  EXPECT_EQ(test::allocation_count(), before);
}

TEST(DeviceProfile, ReadsEveryField) {
  const DeviceProfile p = parse_device_profile(
      "rotation: {axis: [0, 0, 1], angle: 90}\n"
      "translation: [1, 2, 3]\n"
      "scale: 0.5\n"
      "stylus_offset: [0, 0, -12]\n"
      "fixed_orientation: {axis: [0, 1, 0], angle: -25}\n"
      "buttons: {0: clutch, 1: mark_mild}\n"
      "force_enable_below: 0.3\n"
      "ramp_time: 1.5\n"
      "continuous_time_constant: 20\n",
      "lab.yaml");
  EXPECT_LT((p.rotation * Vec3::UnitX() - Vec3::UnitY()).norm(), 1e-12);
  EXPECT_EQ(*p.translation, Vec3(1, 2, 3));
  EXPECT_DOUBLE_EQ(p.scale, 0.5);
  EXPECT_EQ(p.stylus_offset, Vec3(0, 0, -12));
  EXPECT_EQ(profile_actions(p, 0b11), kActionClutch | kActionMarkMild);
  EXPECT_EQ(profile_actions(p, 0b100), 0u);
  EXPECT_DOUBLE_EQ(p.force_enable_below, 0.3);
  EXPECT_DOUBLE_EQ(p.ramp_time, 1.5);
  EXPECT_DOUBLE_EQ(p.continuous_time_constant, 20.0);
}

TEST(DeviceProfile, BadFieldsAreNamedWithTheirPlace) {
  const auto message = [](const std::string& text) {
    try {
      parse_device_profile(text, "lab.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("scale: 0\n").find("lab.yaml:1:8: scale"), std::string::npos) << message("scale: 0\n");
  EXPECT_NE(message("scael: 1\n").find("scale"), std::string::npos);  // unknown key, with a hint
  EXPECT_NE(message("buttons: {0: grab}\n").find("buttons.0"), std::string::npos);
  EXPECT_NE(message("buttons: {99: clutch}\n").find("buttons"), std::string::npos);
  EXPECT_NE(message("rotation: {axis: [0, 0, 0], angle: 3}\n").find("rotation.axis"), std::string::npos);
  EXPECT_NE(message("stylus_offset: [0, .nan, 0]\n").find("stylus_offset"), std::string::npos);
}

}  // namespace
}  // namespace cariesim

namespace cariesim {
namespace {

TEST(DeviceProfile, TheExampleInTheDocsIsAValidProfile) {
  // docs/devices.md "The profile": its YAML block parses, with every key it shows.
  std::ifstream in(std::string(CARIESIM_SOURCE_DIR) + "/docs/devices.md");
  ASSERT_TRUE(in) << "docs/devices.md";
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t section = text.find("## The profile");
  ASSERT_NE(section, std::string::npos);
  const std::size_t begin = text.find("```yaml\n", section);
  ASSERT_NE(begin, std::string::npos);
  const std::size_t end = text.find("```", begin + 8);
  const std::string yaml = text.substr(begin + 8, end - begin - 8);
  const DeviceProfile p = parse_device_profile(yaml, "docs/devices.md");
  EXPECT_DOUBLE_EQ(p.scale, 0.5);
  ASSERT_TRUE(p.translation.has_value());
  ASSERT_TRUE(p.fixed_orientation.has_value());
  EXPECT_EQ(profile_actions(p, 0b1111), kActionClutch | kActionMarkMild | kActionMarkSevere | kActionEndCase);
}

}  // namespace
}  // namespace cariesim
