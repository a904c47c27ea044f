// The `fd` backend (src/device/fd_device.cpp) over the stand-in Force Dimension SDK
// (tests/device/standins/fd/), at the HardwareDevice level, the test thread playing the servo thread.
// The stand-in is loaded through CARIESIM_FD_LIBRARY; the test opens the same file with dlopen (the
// loader hands back the same library) and drives it through its standin_fd_* functions: moving the
// hand, setting buttons and the orientation frame, injecting SDK errors and reading back the wrench
// in the SDK's units (N, N·m). The SDK's frame is x toward the operator, y right, z up, in metres.
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "device/fd_api.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

// Sets an environment variable for a scope, restoring its previous value.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value != nullptr)
      ::setenv(name, value, 1);
    else
      ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_, old_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// The stand-in's test-only functions, resolved on the library the backend loads.
struct StandIn {
  void* handle = nullptr;
  void (*configure)(const char*) = nullptr;
  void (*set_hand)(int, double, double, double) = nullptr;
  void (*place)(int, double, double, double) = nullptr;
  void (*set_frame)(int, const double*) = nullptr;
  void (*set_buttons)(int, unsigned) = nullptr;
  void (*inject_error)(int, int, int) = nullptr;
  int (*wrench)(int, double*) = nullptr;
  int (*is_open)(int) = nullptr;
  int (*autoinit_count)(int) = nullptr;
  void (*set_busy)(int, int) = nullptr;
  void (*deny_access)(int) = nullptr;
  void (*unplug)(int, int) = nullptr;

  explicit StandIn(const char* path) {
    handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) throw Error(std::string("stand-in not loaded: ") + dlerror());
    resolve(configure, "standin_fd_configure");
    resolve(set_hand, "standin_fd_set_hand");
    resolve(place, "standin_fd_place");
    resolve(set_frame, "standin_fd_set_frame");
    resolve(set_buttons, "standin_fd_set_buttons");
    resolve(inject_error, "standin_fd_inject_error");
    resolve(wrench, "standin_fd_wrench");
    resolve(is_open, "standin_fd_is_open");
    resolve(autoinit_count, "standin_fd_autoinit_count");
    resolve(set_busy, "standin_fd_set_busy");
    resolve(deny_access, "standin_fd_deny_access");
    resolve(unplug, "standin_fd_unplug");
  }
  ~StandIn() { dlclose(handle); }
  StandIn(const StandIn&) = delete;
  StandIn& operator=(const StandIn&) = delete;

  template <class F>
  void resolve(F& f, const char* name) {
    f = reinterpret_cast<F>(dlsym(handle, name));
    if (f == nullptr) throw Error(std::string("stand-in lacks ") + name);
  }
  // The last wrench commanded to device `index` (N, N·m, gripper N); `on`: its force is enabled.
  struct Wrench {
    Vec3 force, torque;
    double gripper;
    bool on;
  };
  Wrench last(int index) const {
    double w[7];
    const int on = wrench(index, w);
    return {Vec3(w[0], w[1], w[2]), Vec3(w[3], w[4], w[5]), w[6], on != 0};
  }
};

// Each test: the current stand-in behind CARIESIM_FD_LIBRARY, configured with its devices.
class FdDeviceTest : public ::testing::Test {
 protected:
  FdDeviceTest() : env_("CARIESIM_FD_LIBRARY", CARIESIM_STANDIN_FD), sdk_(CARIESIM_STANDIN_FD) {}
  void SetUp() override { sdk_.configure("omega.6:11001"); }

  // A device opened and homed, its force enabled.
  std::unique_ptr<HardwareDevice> ready(std::string_view spec = "") {
    auto device = make_fd_device(spec);
    device->open();
    const Calibration c = device->calibrate();
    EXPECT_EQ(c.readiness, Readiness::Ready) << c.message;
    device->enable_force(true);
    EXPECT_TRUE(device->read().valid);
    return device;
  }
  static std::string open_error(std::string_view spec) {
    try {
      make_fd_device(spec)->open();
    } catch (const Error& e) {
      return e.what();
    }
    return "(opened)";
  }

  ScopedEnv env_;
  StandIn sdk_;
};

TEST_F(FdDeviceTest, APressAlongEachDeviceAxisIsThatForceInNewtons) {
  auto device = ready();
  for (int axis = 0; axis < 3; ++axis) {
    const Vec3 force = -2.5 * Vec3::Unit(axis);
    device->write(force, Vec3::Zero());
    const StandIn::Wrench w = sdk_.last(0);
    EXPECT_TRUE(w.on);
    EXPECT_NEAR((w.force - force).norm(), 0.0, 1e-12) << "axis " << axis;
  }
  // The simulated handle, held by a hand (400 N/m), settles where the hand balances 2 N along y:
  // 5 mm to the right, read back in mm.
  sdk_.place(0, 0.0, 0.0, 0.0);
  HardwareReading r;
  for (int cycle = 0; cycle < 1500; ++cycle) {  // 1.5 s of a 1 kHz servo loop
    r = device->read();
    device->write(Vec3(0.0, 2.0, 0.0), Vec3::Zero());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(r.valid);
  EXPECT_NEAR(r.pose.p.y(), 5.0, 0.3);
  EXPECT_NEAR(r.pose.p.x(), 0.0, 0.1);
  EXPECT_NEAR(r.pose.p.z(), 0.0, 0.1);
}

TEST_F(FdDeviceTest, TorqueGoesOutInNewtonMetresOnlyOnASixDofOutputDevice) {
  // omega.6: force only; the torque is not sent.
  {
    auto device = ready();
    EXPECT_EQ(device->info().dof_out, 3);
    EXPECT_EQ(device->info().max_torque, 0.0);
    device->write(Vec3(1.0, 0.0, 0.0), Vec3(100.0, 0.0, 0.0));
    EXPECT_EQ(sdk_.last(0).torque, Vec3::Zero());
  }
  // sigma.7: 6-DoF output (N·mm -> N·m), and its gripper's force is written (zero).
  sdk_.configure("sigma.7:22002");
  auto device = ready();
  const HardwareInfo info = device->info();
  EXPECT_EQ(info.model, "sigma.7");
  EXPECT_EQ(info.dof_in, 6);
  EXPECT_EQ(info.dof_out, 6);
  EXPECT_GT(info.max_torque, 0.0);
  device->write(Vec3(0.0, 0.0, 1.0), Vec3(100.0, -50.0, 25.0));
  const StandIn::Wrench w = sdk_.last(0);
  EXPECT_NEAR((w.torque - Vec3(0.1, -0.05, 0.025)).norm(), 0.0, 1e-12);
  EXPECT_EQ(w.gripper, 0.0);
}

TEST_F(FdDeviceTest, PositionsVelocitiesAndTheFrameAreConvertedToMillimetresAndStated) {
  auto device = ready();
  sdk_.place(0, 0.010, -0.020, 0.030);
  const HardwareReading r = device->read();
  ASSERT_TRUE(r.valid);
  EXPECT_NEAR((r.pose.p - Vec3(10.0, -20.0, 30.0)).norm(), 0.0, 0.05);
  // Moving the hand: the handle follows, its velocity in mm/s.
  sdk_.set_hand(0, 0.040, -0.020, 0.030);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const HardwareReading moving = device->read();
  EXPECT_GT(moving.velocity.x(), 10.0);  // mm/s; m/s would be below 1
  // Force Dimension's axes in the operator frame: x toward the operator is -y, y right is +x.
  const HardwareInfo info = device->info();
  EXPECT_NEAR((info.axes * Vec3::UnitX() - Vec3(0.0, -1.0, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((info.axes * Vec3::UnitY() - Vec3(1.0, 0.0, 0.0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((info.axes * Vec3::UnitZ() - Vec3::UnitZ()).norm(), 0.0, 1e-12);
  EXPECT_EQ(info.backend, "fd");
  EXPECT_EQ(info.serial, "11001");
  EXPECT_NE(info.sdk.find(CARIESIM_STANDIN_FD), std::string::npos);
  EXPECT_NE(info.sdk.find("3.17.6"), std::string::npos);
}

TEST_F(FdDeviceTest, TheOrientationFrameIsTheReadingsRotation) {
  auto device = ready();
  const Eigen::AngleAxisd turn(0.5, Vec3(1.0, 2.0, -1.0).normalized());
  const Mat3 m = turn.toRotationMatrix();
  const double frame[9] = {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
  sdk_.set_frame(0, frame);
  const HardwareReading r = device->read();
  ASSERT_TRUE(r.valid);
  EXPECT_NEAR(r.pose.q.angularDistance(Quat(turn)), 0.0, 1e-9);
}

TEST_F(FdDeviceTest, ButtonsAreTheSdksMask) {
  auto device = ready();
  sdk_.set_buttons(0, 0b101u);
  EXPECT_EQ(device->read().buttons, 0b101u);
  sdk_.set_buttons(0, 0u);
  EXPECT_EQ(device->read().buttons, 0u);
}

TEST_F(FdDeviceTest, AnUninitialisedDeviceHomesRoboticallyOnceAndSaysSo) {
  sdk_.configure("omega.6:11001:unhomed");
  auto device = make_fd_device("");
  device->open();
  const Calibration first = device->calibrate();
  EXPECT_EQ(first.readiness, Readiness::Ready);
  EXPECT_NE(first.message.find("homing (robotic)"), std::string::npos) << first.message;
  EXPECT_EQ(sdk_.autoinit_count(0), 1);
  // Homing leaves the force off until it is enabled.
  EXPECT_FALSE(sdk_.last(0).on);
  const Calibration again = device->calibrate();
  EXPECT_EQ(again.readiness, Readiness::Ready);
  EXPECT_EQ(sdk_.autoinit_count(0), 1);
}

TEST_F(FdDeviceTest, AFalconNotHomedByHandRefusesForceUntilItIs) {
  sdk_.configure("falcon:777:unhomed");
  auto device = make_fd_device("");
  device->open();
  const HardwareInfo info = device->info();
  EXPECT_EQ(info.dof_in, 3);
  EXPECT_EQ(info.dof_out, 3);
  EXPECT_EQ(info.buttons, 4);
  const Calibration c = device->calibrate();
  EXPECT_EQ(c.readiness, Readiness::NeedsOperator);
  EXPECT_NE(c.message.find("home the Falcon by hand"), std::string::npos) << c.message;
  EXPECT_EQ(sdk_.autoinit_count(0), 0);
  // Force is refused (and the device's switch stays off) while it is not homed.
  device->enable_force(true);
  EXPECT_FALSE(sdk_.last(0).on);
  const HardwareReading refused = device->read();
  EXPECT_FALSE(refused.valid);
  EXPECT_NE(refused.faults & kHardwareNotCalibrated, 0u);
  // The operator pulls the grip toward them, then pushes it in: homed.
  sdk_.place(0, 0.045, 0.0, 0.0);
  sdk_.place(0, -0.045, 0.0, 0.0);
  EXPECT_EQ(device->calibrate().readiness, Readiness::Ready);
  device->enable_force(true);
  EXPECT_TRUE(sdk_.last(0).on);
  // The Falcon senses no orientation: the reading's is the identity.
  const double turned[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  sdk_.set_frame(0, turned);
  EXPECT_TRUE(device->read().pose.q.isApprox(Quat::Identity()));
}

TEST_F(FdDeviceTest, AnSdkErrorMidRunZeroesTheForceInTheSameCycle) {
  auto device = ready();
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  ASSERT_EQ(sdk_.last(0).force, Vec3(0.0, 0.0, 3.0));
  // One timed-out call: the reading carries the fault and the force is zero before read() returns.
  sdk_.inject_error(0, fd::kErrorTimeout, 1);
  const HardwareReading r = device->read();
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.faults, static_cast<uint32_t>(kHardwareCommunication));
  EXPECT_EQ(sdk_.last(0).force, Vec3::Zero());
  // The cycle's write sends zero whatever it is given; the next good reading lets force through.
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  EXPECT_EQ(sdk_.last(0).force, Vec3::Zero());
  EXPECT_TRUE(device->read().valid);
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  EXPECT_EQ(sdk_.last(0).force, Vec3(0.0, 0.0, 3.0));
  // An error in write(): zero at once and the next reading carries it.
  sdk_.inject_error(0, fd::kErrorCom, 1);
  device->write(Vec3(1.0, 0.0, 0.0), Vec3::Zero());
  EXPECT_EQ(sdk_.last(0).force, Vec3::Zero());
  EXPECT_EQ(device->read().faults, static_cast<uint32_t>(kHardwareCommunication));
  // Each error code's fault bit ("no device" last: the backend then takes the device for lost and
  // reopens it, see AnUnpluggedDeviceIsReopenedWhenItIsPluggedBackForceOff).
  const std::pair<int, uint32_t> codes[] = {{fd::kErrorCom, kHardwareCommunication},
                                            {fd::kErrorDeviceNotReady, kHardwareNotCalibrated},
                                            {fd::kErrorGeometry, kHardwareOther},
                                            {fd::kErrorNoDeviceFound, kHardwareLost}};
  for (const auto& [code, bit] : codes) {
    sdk_.inject_error(0, code, 1);
    EXPECT_EQ(device->read().faults, bit) << "DHD error " << code;
  }
}

TEST_F(FdDeviceTest, ACableLostForGoodKeepsEveryReadingInvalid) {
  auto device = ready();
  sdk_.inject_error(0, fd::kErrorCom, -1);
  for (int i = 0; i < 5; ++i) {
    const HardwareReading r = device->read();
    EXPECT_FALSE(r.valid);
    EXPECT_NE(r.faults & kHardwareCommunication, 0u);
  }
  EXPECT_FALSE(sdk_.last(0).on);
}

// Reads (one servo cycle each, 1 ms apart) until `done` holds of a reading or 3 s pass; that reading.
template <class Done>
HardwareReading read_until(HardwareDevice& device, Done done) {
  HardwareReading r = device.read();
  for (int i = 0; i < 3000 && !done(r); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    r = device.read();
  }
  return r;
}

TEST_F(FdDeviceTest, AnUnpluggedDeviceIsReopenedWhenItIsPluggedBackForceOff) {
  auto device = ready();
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  ASSERT_TRUE(sdk_.last(0).on);
  // Unplugged: the first reading is invalid and the motors are off; a communication error that
  // persists becomes "device lost".
  sdk_.unplug(0, 1);
  HardwareReading r = device->read();
  EXPECT_FALSE(r.valid);
  EXPECT_NE(r.faults & kHardwareCommunication, 0u);
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  EXPECT_FALSE(sdk_.last(0).on);
  r = read_until(*device, [](const HardwareReading& x) { return (x.faults & kHardwareLost) != 0; });
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.faults & kHardwareLost, static_cast<uint32_t>(kHardwareLost));
  for (int i = 0; i < 50; ++i) {
    r = device->read();
    EXPECT_FALSE(r.valid);
    EXPECT_NE(r.faults & kHardwareLost, 0u);
    device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_FALSE(sdk_.last(0).on);

  // Plugged back: the reopen thread closes the dead handle and opens it again, force off; the
  // readings are valid again and force returns only when it is enabled again.
  sdk_.unplug(0, 0);
  r = read_until(*device, [](const HardwareReading& x) { return x.valid; });
  ASSERT_TRUE(r.valid) << describe_hardware_faults(r.faults);
  EXPECT_EQ(sdk_.is_open(0), 1);
  EXPECT_FALSE(sdk_.last(0).on);
  device->enable_force(true);
  device->write(Vec3(0.0, 0.0, 2.0), Vec3::Zero());
  EXPECT_TRUE(sdk_.last(0).on);
  EXPECT_EQ(sdk_.last(0).force, Vec3(0.0, 0.0, 2.0));
  device->close();
  EXPECT_EQ(sdk_.is_open(0), 0);
}

TEST_F(FdDeviceTest, ADeviceStillUnpluggedAtCloseClosesCleanly) {
  auto device = ready();
  sdk_.unplug(0, 1);
  read_until(*device, [](const HardwareReading& x) { return (x.faults & kHardwareLost) != 0; });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the reopen thread closed the handle
  device->close();
  EXPECT_EQ(sdk_.is_open(0), 0);
  EXPECT_FALSE(sdk_.last(0).on);
}

TEST_F(FdDeviceTest, TheServoCallsAllocateNothing) {
  auto device = ready();
  device->read();
  const std::size_t before = test::allocation_count();
  for (int i = 0; i < 100; ++i) {
    const HardwareReading r = device->read();
    device->write(Vec3(0.0, 0.0, 0.01 * i), Vec3::Zero());
    device->enable_force(r.valid);
  }
  sdk_.inject_error(0, fd::kErrorTimeout, 1);
  device->read();
  EXPECT_EQ(test::allocation_count(), before);
}

TEST_F(FdDeviceTest, ClosingSwitchesTheForceOffAndClosesTheDevice) {
  auto device = ready();
  device->write(Vec3(2.0, 0.0, 0.0), Vec3::Zero());
  ASSERT_TRUE(sdk_.last(0).on);
  device->close();
  const StandIn::Wrench w = sdk_.last(0);
  EXPECT_FALSE(w.on);
  EXPECT_EQ(w.force, Vec3::Zero());
  EXPECT_EQ(sdk_.is_open(0), 0);
  device->close();  // twice: nothing
  // A device destroyed open is closed, its force off.
  {
    auto other = ready();
    other->write(Vec3(2.0, 0.0, 0.0), Vec3::Zero());
  }
  EXPECT_EQ(sdk_.is_open(0), 0);
  EXPECT_FALSE(sdk_.last(0).on);
}

TEST_F(FdDeviceTest, OpensByIndexOrSerial) {
  sdk_.configure("omega.6:11001,sigma.7:22002");
  auto by_index = make_fd_device("1");
  by_index->open();
  EXPECT_EQ(by_index->info().model, "sigma.7");
  by_index->close();
  auto by_serial = make_fd_device("22002");
  by_serial->open();
  EXPECT_EQ(by_serial->info().serial, "22002");
  by_serial->close();
  EXPECT_NE(open_error("3").find("no device at index 3 (2 attached"), std::string::npos) << open_error("3");
  EXPECT_NE(open_error("12345").find("no device at serial 12345"), std::string::npos);
  for (const char* bad : {"omega", "-1", "1x"}) {
    try {
      make_fd_device(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("expected fd[:INDEX|SERIAL]"), std::string::npos) << e.what();
    }
  }
}

TEST_F(FdDeviceTest, BusyAbsentAndForbiddenDevicesEachSayWhatToDo) {
  sdk_.set_busy(0, 1);
  const std::string busy = open_error("");
  EXPECT_NE(busy.find("in use by another program"), std::string::npos) << busy;
  EXPECT_NE(busy.find("device in use"), std::string::npos) << busy;  // the SDK's own words
  sdk_.set_busy(0, 0);

  sdk_.deny_access(1);
  const std::string forbidden = open_error("");
  EXPECT_NE(forbidden.find("no permission"), std::string::npos) << forbidden;
  EXPECT_NE(forbidden.find("/etc/udev/rules.d/99-forcedimension.rules"), std::string::npos) << forbidden;
  sdk_.deny_access(0);

  sdk_.configure("");
  const std::string none = open_error("");
  EXPECT_NE(none.find("no Force Dimension device found"), std::string::npos) << none;
  EXPECT_NE(none.find("udev rule"), std::string::npos) << none;
}

TEST_F(FdDeviceTest, TheDhdLibraryAloneDrivesADeviceButCannotHomeIt) {
  const ScopedEnv dhd("CARIESIM_FD_LIBRARY", CARIESIM_STANDIN_FD_DHD);
  StandIn dhd_sdk(CARIESIM_STANDIN_FD_DHD);
  dhd_sdk.configure("omega.6:11001");
  auto device = make_fd_device("");
  device->open();
  const Calibration c = device->calibrate();
  EXPECT_EQ(c.readiness, Readiness::Ready);
  EXPECT_NE(c.message.find("homing not checked"), std::string::npos) << c.message;
  device->enable_force(true);
  device->write(Vec3(0.0, 1.0, 0.0), Vec3::Zero());
  EXPECT_EQ(dhd_sdk.last(0).force, Vec3(0.0, 1.0, 0.0));
}

// Through the factory: `fd` is a HapticDevice over the backend, mapped onto the scene.
class FdThroughTheFactory : public FdDeviceTest {
 protected:
  void SetUp() override {
    FdDeviceTest::SetUp();
    // No ramp, so that one cycle's force is the scene's.
    profile_ = std::filesystem::temp_directory_path() /
               ("cariesim_fd_profile_" + std::to_string(::getpid()) + ".yaml");
    std::ofstream(profile_) << "ramp_time: 0\n";
  }
  void TearDown() override { std::filesystem::remove(profile_); }
  std::unique_ptr<Device> make(const std::string& spec = "fd") {
    DeviceOptions options;
    options.home.p = Vec3(1.0, 2.0, 12.0);
    options.profile = profile_;
    return make_device(spec, options);
  }
  std::filesystem::path profile_;
};

TEST_F(FdThroughTheFactory, ASceneForceReachesTheDeviceAlongItsOwnAxes) {
  auto device = make();
  device->start();
  EXPECT_EQ(device->info().name, "fd");
  // Out of contact first (the force switch goes on at a small force), then 2 N to the operator's right
  // (scene x): Force Dimension's +y; then 1.5 N away from the operator (scene y): its -x.
  device->read(0.0);
  device->write(Vec3::Zero(), Vec3::Zero());
  EXPECT_TRUE(sdk_.last(0).on);
  device->read(0.001);
  device->write(Vec3(2.0, 0.0, 0.0), Vec3::Zero());
  EXPECT_NEAR((sdk_.last(0).force - Vec3(0.0, 2.0, 0.0)).norm(), 0.0, 1e-9) << sdk_.last(0).force.transpose();
  device->read(0.002);
  device->write(Vec3(0.0, 1.5, 0.0), Vec3::Zero());
  EXPECT_NEAR((sdk_.last(0).force - Vec3(-1.5, 0.0, 0.0)).norm(), 0.0, 1e-9)
      << sdk_.last(0).force.transpose();
  // The hand 10 mm toward the operator (Force Dimension's +x): the tool 10 mm toward the operator in
  // the scene (-y), from the tool home where the workspace centre maps.
  sdk_.place(0, 0.0, 0.0, 0.0);
  const Vec3 centre = device->read(0.003).pose.p;
  EXPECT_NEAR((centre - Vec3(1.0, 2.0, 12.0)).norm(), 0.0, 1e-6);
  sdk_.place(0, 0.010, 0.0, 0.0);
  const Vec3 moved = device->read(0.004).pose.p;
  EXPECT_NEAR((moved - centre - Vec3(0.0, -10.0, 0.0)).norm(), 0.0, 1e-6) << moved.transpose();
  // Buttons become the profile's actions (button 1: mark mild).
  sdk_.set_buttons(0, 0b10u);
  EXPECT_EQ(device->read(0.005).actions, static_cast<uint32_t>(kActionMarkMild));
  device->stop();
  EXPECT_FALSE(sdk_.last(0).on);
  EXPECT_EQ(sdk_.is_open(0), 0);
}

TEST_F(FdThroughTheFactory, AnSdkErrorZeroesTheForceInTheSameCycle) {
  auto device = make();
  device->start();
  device->read(0.0);
  device->write(Vec3::Zero(), Vec3::Zero());
  device->read(0.001);
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  ASSERT_NEAR(sdk_.last(0).force.norm(), 3.0, 1e-9);
  sdk_.inject_error(0, fd::kErrorTimeout, 1);
  const DeviceState state = device->read(0.002);
  EXPECT_FALSE(state.valid);
  EXPECT_EQ(sdk_.last(0).force, Vec3::Zero());
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  EXPECT_EQ(sdk_.last(0).force, Vec3::Zero());
  device->stop();
}

TEST_F(FdThroughTheFactory, UnpluggedAndBackTheForceReturnsThroughTheGateAndTheRamp) {
  std::ofstream(profile_) << "ramp_time: 0.5\n";
  auto device = make();
  device->start();
  const auto* haptic = dynamic_cast<const HapticDevice*>(device.get());
  ASSERT_NE(haptic, nullptr);
  double t = 0.0;
  device->read(t);
  device->write(Vec3::Zero(), Vec3::Zero());
  t = 1.0;
  device->read(t);
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  ASSERT_TRUE(sdk_.last(0).on);
  ASSERT_NEAR(sdk_.last(0).force.norm(), 3.0, 1e-9);

  // Unplugged: no force from the first cycle on; once lost, the force switch is off.
  sdk_.unplug(0, 1);
  t += 0.001;
  EXPECT_FALSE(device->read(t).valid);
  device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
  EXPECT_FALSE(sdk_.last(0).on);
  for (int i = 0; i < 3000 && (haptic->status().faults & kHardwareLost) == 0; ++i) {
    t += 0.001;
    device->read(t);
    device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_NE(haptic->status().faults & kHardwareLost, 0u);
  EXPECT_FALSE(haptic->status().force_enabled);

  // Back: valid readings; a large force waits, a small one passes the gate and ramps in.
  sdk_.unplug(0, 0);
  bool valid = false;
  for (int i = 0; i < 3000 && !valid; ++i) {
    t += 0.001;
    valid = device->read(t).valid;
    device->write(Vec3(0.0, 0.0, 3.0), Vec3::Zero());
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(valid);
  EXPECT_EQ(haptic->status().faults, 0u);
  EXPECT_FALSE(sdk_.last(0).on);
  EXPECT_FALSE(haptic->status().force_enabled);
  t += 0.001;
  device->read(t);
  device->write(Vec3(0.0, 0.0, 0.2), Vec3::Zero());
  EXPECT_TRUE(sdk_.last(0).on);
  EXPECT_LT(sdk_.last(0).force.norm(), 0.01);
  t += 0.25;
  device->read(t);
  device->write(Vec3(0.0, 0.0, 2.0), Vec3::Zero());
  EXPECT_NEAR(sdk_.last(0).force.norm(), 1.0, 0.02);
  device->stop();
}

TEST_F(FdThroughTheFactory, SpecAndSdkErrorsNameTheSpec) {
  try {
    make("fd:omega");
    ADD_FAILURE() << "fd:omega accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("device spec 'fd:omega'"), std::string::npos) << e.what();
  }
  const ScopedEnv missing("CARIESIM_FD_LIBRARY", "/nonexistent/libdrd.so.3");
  try {
    make("fd:1");
    ADD_FAILURE() << "loaded a missing SDK";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("device spec 'fd:1': Force Dimension SDK: not found"),
              std::string::npos)
        << e.what();
  }
}

// What make_fd_device says when the SDK cannot be used.
std::string load_error(const char* library) {
  const ScopedEnv env("CARIESIM_FD_LIBRARY", library);
  try {
    make_fd_device("");
  } catch (const Error& e) {
    return e.what();
  }
  return "(loaded)";
}

TEST(FdSdk, AMissingLibraryNamesWhatWasTriedAndWhatToInstall) {
  const std::string overridden = load_error("/nonexistent/libdrd.so.3");
  EXPECT_NE(overridden.find("Force Dimension SDK: not found"), std::string::npos) << overridden;
  EXPECT_NE(overridden.find("/nonexistent/libdrd.so.3"), std::string::npos) << overridden;
  EXPECT_NE(overridden.find("CARIESIM_FD_LIBRARY"), std::string::npos) << overridden;
  // Without the variable: libdrd.so.3, then libdhd.so.3 (neither is installed on a test machine).
  const std::string searched = load_error(nullptr);
  const std::size_t drd = searched.find("libdrd.so.3"), dhd = searched.find("libdhd.so.3");
  EXPECT_NE(drd, std::string::npos) << searched;
  EXPECT_NE(dhd, std::string::npos) << searched;
  EXPECT_LT(drd, dhd) << searched;
  EXPECT_NE(searched.find("forcedimension.com"), std::string::npos) << searched;
}

TEST(FdSdk, AMissingSymbolIsNamed) {
  const std::string e = load_error(CARIESIM_STANDIN_FD_NOSYM);
  EXPECT_NE(e.find("missing symbol dhdGetOrientationFrame"), std::string::npos) << e;
}

TEST(FdSdk, AnOldSdkIsRefusedNamingBothVersions) {
  const std::string e = load_error(CARIESIM_STANDIN_FD_OLD);
  EXPECT_NE(e.find("version 3.2.0.4242"), std::string::npos) << e;
  EXPECT_NE(e.find("older than 3.3.0"), std::string::npos) << e;
  EXPECT_EQ(e.find("missing symbol"), std::string::npos) << e;
}

TEST(FdSdk, TheSurveyListsEachDeviceOrSaysWhy) {
  {
    const ScopedEnv env("CARIESIM_FD_LIBRARY", CARIESIM_STANDIN_FD);
    StandIn sdk(CARIESIM_STANDIN_FD);
    sdk.configure("omega.6:11001,falcon:777");
    const HardwareSurvey s = survey_fd();
    EXPECT_EQ(s.backend, "fd");
    ASSERT_TRUE(s.sdk.path.has_value());
    EXPECT_EQ(s.version, "3.17.6.4242");
    ASSERT_EQ(s.devices.size(), 2u) << s.problem;
    EXPECT_EQ(s.devices[0].model, "omega.6");
    EXPECT_EQ(s.devices[1].model, "Falcon");
    EXPECT_EQ(s.devices[1].serial, "777");
    EXPECT_EQ(sdk.is_open(0), 0);
    EXPECT_EQ(sdk.is_open(1), 0);
  }
  {
    const ScopedEnv env("CARIESIM_FD_LIBRARY", CARIESIM_STANDIN_FD_OLD);
    const HardwareSurvey s = survey_fd();
    EXPECT_EQ(s.version, "3.2.0.4242");
    EXPECT_NE(s.problem.find("older than 3.3.0"), std::string::npos) << s.problem;
  }
  {
    const ScopedEnv env("CARIESIM_FD_LIBRARY", "/nonexistent/libdrd.so.3");
    const HardwareSurvey s = survey_fd();
    EXPECT_FALSE(s.sdk.path.has_value());
    EXPECT_NE(s.install.find("forcedimension.com"), std::string::npos);
    EXPECT_TRUE(s.devices.empty());
  }
}

}  // namespace
}  // namespace cariesim
