// The `touch` backend (OpenHaptics HD) against the stand-in libHD.so the tests build
// (tests/device/standins/hd): opening by name with the default device as fallback, the SDK's
// messages (no library, a missing symbol, an old SDK, no device, busy, no permission), the device's
// limits in the project's units, HD's clock (ticks on the scheduler's thread at its rate, inside a
// frame; stop returns after the last tick), a press along each HD axis read back in HD's units,
// torque on a 6-DoF device, orientation and buttons, calibration refusing force until the stylus is
// in the inkwell, an HD error zeroing the force in the same cycle, close switching force off.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/device/haptic_device.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "device/touch_api.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using namespace std::chrono_literals;

// The stand-in's test-only functions, resolved on the same library the backend loads.
struct Standin {
  Standin() {
    handle = dlopen(CARIESIM_STANDIN_HD, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) throw std::runtime_error(std::string("stand-in: ") + dlerror());
    reset = fn<void (*)()>("standin_hd_reset");
    configure = fn<void (*)(const char*, const char*, int, int, double)>("standin_hd_configure");
    set_version = fn<void (*)(const char*)>("standin_hd_set_version");
    fail_open = fn<void (*)(unsigned, int, int)>("standin_hd_fail_open");
    set_calibration = fn<void (*)(unsigned)>("standin_hd_set_calibration");
    set_inkwell = fn<void (*)(int)>("standin_hd_set_inkwell");
    push_hand = fn<void (*)(double, double, double)>("standin_hd_push_hand");
    place = fn<void (*)(double, double, double)>("standin_hd_place");
    set_orientation = fn<void (*)(double, double, double, double)>("standin_hd_set_orientation");
    set_buttons = fn<void (*)(int)>("standin_hd_set_buttons");
    inject_error = fn<void (*)(unsigned, int, int)>("standin_hd_inject_error");
    output = fn<void (*)(double*, double*)>("standin_hd_output");
    force_output_enabled = fn<int (*)()>("standin_hd_force_output_enabled");
    is_open = fn<int (*)()>("standin_hd_is_open");
    frame_violations = fn<int (*)()>("standin_hd_frame_violations");
    on_scheduler_thread = fn<int (*)()>("standin_hd_on_scheduler_thread");
    unplug = fn<void (*)(int)>("standin_hd_unplug");
    set_scheduler_rate = fn<void (*)(hd::HDulong)>("hdSetSchedulerRate");
  }
  ~Standin() { dlclose(handle); }
  template <class F>
  F fn(const char* name) {
    void* address = dlsym(handle, name);
    if (address == nullptr) throw std::runtime_error(std::string("stand-in lacks ") + name);
    return reinterpret_cast<F>(address);
  }
  [[nodiscard]] Vec3 force() const {
    double f[3];
    double t[3];
    output(f, t);
    return {f[0], f[1], f[2]};
  }
  [[nodiscard]] Vec3 torque() const {
    double f[3];
    double t[3];
    output(f, t);
    return {t[0], t[1], t[2]};
  }
  void* handle = nullptr;
  void (*reset)();
  void (*configure)(const char*, const char*, int, int, double);
  void (*set_version)(const char*);
  void (*fail_open)(unsigned, int, int);
  void (*set_calibration)(unsigned);
  void (*set_inkwell)(int);
  void (*push_hand)(double, double, double);
  void (*place)(double, double, double);
  void (*set_orientation)(double, double, double, double);
  void (*set_buttons)(int);
  void (*inject_error)(unsigned, int, int);
  void (*output)(double*, double*);
  int (*force_output_enabled)();
  int (*is_open)();
  int (*frame_violations)();
  int (*on_scheduler_thread)();
  void (*unplug)(int);
  void (*set_scheduler_rate)(hd::HDulong);
};

// What the servo tick does and saw: the test thread sets the command, the tick records.
struct Servo {
  HardwareDevice* device = nullptr;
  const Standin* standin = nullptr;
  std::atomic<bool> enable{false};
  std::atomic<double> fx{0.0}, fy{0.0}, fz{0.0};  // N, HD frame
  std::atomic<double> tx{0.0}, ty{0.0}, tz{0.0};  // N·mm
  std::atomic<int> ticks{0};
  std::atomic<int> off_thread{0};  // ticks that ran anywhere but on HD's scheduler thread
  std::mutex mutex;
  HardwareReading last;
  // Per tick: the faults of its reading and what the motors rendered after the previous tick.
  struct Cycle {
    uint32_t faults;
    double previous_output;  // N, |force| the previous tick committed
  };
  std::vector<Cycle> cycles;

  static void tick(void* context) {
    auto* s = static_cast<Servo*>(context);
    const double previous_output = s->standin->force().norm();
    if (s->standin->on_scheduler_thread() == 0) s->off_thread.fetch_add(1);
    s->device->enable_force(s->enable.load());
    const HardwareReading r = s->device->read();
    s->device->write(Vec3(s->fx.load(), s->fy.load(), s->fz.load()),
                     Vec3(s->tx.load(), s->ty.load(), s->tz.load()));
    {
      std::lock_guard<std::mutex> lock(s->mutex);
      s->last = r;
      if (s->cycles.size() < s->cycles.capacity()) s->cycles.push_back({r.faults, previous_output});
    }
    s->ticks.fetch_add(1);
  }
  HardwareReading reading() {
    std::lock_guard<std::mutex> lock(mutex);
    return last;
  }
  // Waits until `n` more ticks ran (bounded, so a stalled clock fails instead of hanging).
  void wait_ticks(int n) {
    const int target = ticks.load() + n;
    for (int i = 0; i < 2000 && ticks.load() < target; ++i) std::this_thread::sleep_for(1ms);
  }
};

class TouchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    setenv("CARIESIM_HD_LIBRARY", CARIESIM_STANDIN_HD, 1);
    standin.reset();
  }
  void TearDown() override {
    standin.reset();
    unsetenv("CARIESIM_HD_LIBRARY");
  }
  // Opens the device and starts its clock with the test's servo tick.
  std::unique_ptr<HardwareDevice> start(Servo& servo, std::string_view name = "") {
    auto device = make_touch_device(name);
    device->open();
    servo.device = device.get();
    servo.standin = &standin;
    servo.cycles.reserve(20000);
    device->clock()->start_clock(&Servo::tick, &servo);
    servo.wait_ticks(5);
    return device;
  }
  std::string open_error(std::string_view name = "") {
    try {
      make_touch_device(name)->open();
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }
  Standin standin;
};

TEST_F(TouchTest, OpensAndStatesTheDeviceInTheProjectsUnitsAndHdsAxes) {
  auto device = make_touch_device("Default Device");
  device->open();
  const HardwareInfo info = device->info();
  EXPECT_EQ(info.backend, "touch");
  EXPECT_EQ(info.model, "Touch");
  EXPECT_EQ(info.serial, "220-00042");
  EXPECT_NE(info.sdk.find(CARIESIM_STANDIN_HD), std::string::npos) << info.sdk;
  EXPECT_NE(info.sdk.find("3.4.0"), std::string::npos) << info.sdk;
  EXPECT_EQ(info.dof_in, 6);
  EXPECT_EQ(info.dof_out, 3);
  EXPECT_DOUBLE_EQ(info.max_force, 3.3);
  EXPECT_DOUBLE_EQ(info.continuous_force, 0.88);
  EXPECT_DOUBLE_EQ(info.max_stiffness, 1.26);
  EXPECT_DOUBLE_EQ(info.max_torque, 0.0);
  EXPECT_DOUBLE_EQ(info.rate_hz, 1000.0);
  EXPECT_TRUE(info.workspace.min().isApprox(Vec3(-80, -60, -35)));
  EXPECT_TRUE(info.workspace.max().isApprox(Vec3(80, 60, 35)));
  // HD: x right, y up, z toward the user; the operator frame: x right, y away, z up.
  EXPECT_TRUE((info.axes * Vec3::UnitX()).isApprox(Vec3::UnitX()));
  EXPECT_TRUE((info.axes * Vec3::UnitY()).isApprox(Vec3::UnitZ()));
  EXPECT_TRUE((info.axes * Vec3::UnitZ()).isApprox(-Vec3::UnitY()));
  // Opened with force output off (HD switches it on at hdInitDevice).
  EXPECT_EQ(standin.force_output_enabled(), 0);
  EXPECT_EQ(standin.is_open(), 1);
}

TEST_F(TouchTest, ANameThatFailsFallsBackToTheDefaultDevice) {
  auto device = make_touch_device("Left Touch");  // no such configuration
  EXPECT_NO_THROW(device->open());
  EXPECT_EQ(standin.is_open(), 1);
  device->close();
  // The default fails on some installs: the name opens then.
  standin.fail_open(0, 0, 1);
  auto named = make_touch_device("Default Device");
  EXPECT_NO_THROW(named->open());
  named->close();
  // Both fail: both reasons are told.
  const std::string message = open_error("Left Touch");
  EXPECT_NE(message.find("device 'Left Touch' (HD_COMM_CONFIG_ERROR"), std::string::npos) << message;
  EXPECT_NE(message.find("nor the default device (no device answered"), std::string::npos) << message;
  EXPECT_NE(message.find("HD_DEVICE_FAULT"), std::string::npos) << message;
}

TEST_F(TouchTest, NoDeviceBusyAndNoPermissionEachGiveTheirMessage) {
  standin.fail_open(hd::kDeviceFault, 0, 0);
  std::string message = open_error();
  EXPECT_NE(message.find("cannot open the default device: no device answered"), std::string::npos) << message;
  standin.reset();
  standin.fail_open(hd::kCommError, EBUSY, 0);
  message = open_error();
  EXPECT_NE(message.find("device busy: another program holds it"), std::string::npos) << message;
  EXPECT_NE(message.find("HD_COMM_ERROR (0x0302"), std::string::npos) << message;
  standin.reset();
  standin.fail_open(hd::kCommError, EACCES, 0);
  message = open_error();
  EXPECT_NE(message.find("no permission to open the device: add the udev rule"), std::string::npos)
      << message;
  standin.reset();
  auto first = make_touch_device("");
  first->open();
  message = open_error();
  EXPECT_NE(message.find("device busy: it is already open in this program"), std::string::npos) << message;
}

TEST_F(TouchTest, AMissingLibraryAMissingSymbolAndAnOldSdkEachGiveTheirMessage) {
  setenv("CARIESIM_HD_LIBRARY", "/nonexistent/libHD.so", 1);
  try {
    (void)make_touch_device("");
    ADD_FAILURE() << "no library, yet a device";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("OpenHaptics HD: not found (tried /nonexistent/libHD.so"), std::string::npos)
        << message;
    EXPECT_NE(message.find("CARIESIM_HD_LIBRARY"), std::string::npos) << message;
    EXPECT_NE(message.find("install 3D Systems' OpenHaptics"), std::string::npos) << message;
  }
  setenv("CARIESIM_HD_LIBRARY", CARIESIM_STANDIN_HD_PARTIAL, 1);
  try {
    (void)make_touch_device("");
    ADD_FAILURE() << "a symbol missing, yet a device";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing symbol hdUpdateCalibration"), std::string::npos)
        << e.what();
  }
  setenv("CARIESIM_HD_LIBRARY", CARIESIM_STANDIN_HD, 1);
  standin.set_version("2.10.1");
  const std::string message = open_error();
  EXPECT_NE(message.find("is OpenHaptics HD 2.10.1, older than 3.0"), std::string::npos) << message;
  EXPECT_EQ(standin.is_open(), 0) << "the refused device is released";
}

TEST_F(TouchTest, TheClockTicksOnHdsSchedulerThreadAtItsRateAndStopReturnsAfterTheLastTick) {
  standin.set_scheduler_rate(500);
  Servo servo;
  auto device = start(servo);
  EXPECT_DOUBLE_EQ(device->clock()->rate_hz(), 500.0);
  const int before = servo.ticks.load();
  std::this_thread::sleep_for(400ms);
  const int ticked = servo.ticks.load() - before;
  EXPECT_GT(ticked, 100);  // 200 at 500 Hz; a loaded machine loses some
  EXPECT_LT(ticked, 260);
  device->clock()->stop_clock();
  const int stopped_at = servo.ticks.load();
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(servo.ticks.load(), stopped_at) << "a tick after stop_clock returned";
  EXPECT_EQ(servo.off_thread.load(), 0);
  EXPECT_EQ(standin.frame_violations(), 0) << "every force was written inside a frame";
  device->clock()->stop_clock();  // twice is safe
}

TEST_F(TouchTest, APressAlongEachHdAxisIsRenderedAlongItInNewtons) {
  Servo servo;
  auto device = start(servo);
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  const Vec3 axes[] = {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  for (const Vec3& axis : axes) {
    const Vec3 press = 1.5 * axis;  // N
    servo.fx = press.x();
    servo.fy = press.y();
    servo.fz = press.z();
    servo.wait_ticks(200);
    EXPECT_TRUE(standin.force().isApprox(press, 1e-12)) << standin.force().transpose();
    // The stylus gives way along the press against the hand's 2 N/mm: 0.75 mm.
    const HardwareReading r = servo.reading();
    EXPECT_TRUE(r.valid);
    EXPECT_NEAR(r.pose.p.dot(axis), 0.75, 0.05) << r.pose.p.transpose();
  }
  EXPECT_EQ(standin.torque(), Vec3::Zero()) << "a 3-DoF-force device gets no torque";
  EXPECT_EQ(servo.reading().faults, 0u);
}

TEST_F(TouchTest, ASixDofDeviceGetsTheTorqueInMilliNewtonMetres) {
  standin.configure("Premium", "PHANToM Premium 1.5 6DOF", 6, hd::kCalibrationEncoderReset, 188.0);
  Servo servo;
  auto device = start(servo, "Premium");
  EXPECT_EQ(device->info().dof_out, 6);
  EXPECT_DOUBLE_EQ(device->info().max_torque, 188.0);  // mN·m is N·mm
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  servo.tx = 10.0;
  servo.ty = -20.0;
  servo.tz = 30.0;
  servo.wait_ticks(50);
  EXPECT_TRUE(standin.torque().isApprox(Vec3(10.0, -20.0, 30.0), 1e-12)) << standin.torque().transpose();
}

TEST_F(TouchTest, ThePoseOrientationAndButtonsAreReadInHdsFrame) {
  Servo servo;
  standin.place(10.0, 20.0, 30.0);
  const Quat q(Eigen::AngleAxisd(0.5, Vec3(1.0, 2.0, -0.5).normalized()));
  standin.set_orientation(q.w(), q.x(), q.y(), q.z());
  standin.set_buttons(0b10);
  auto device = start(servo);
  servo.wait_ticks(20);
  HardwareReading r = servo.reading();
  EXPECT_TRUE(r.valid);
  EXPECT_TRUE(r.pose.p.isApprox(Vec3(10.0, 20.0, 30.0), 1e-9)) << r.pose.p.transpose();
  EXPECT_LT(r.pose.q.angularDistance(q), 1e-9);
  EXPECT_EQ(r.buttons, 0b10u);
  standin.set_buttons(0b01);
  standin.push_hand(10.0, 20.0, 40.0);  // the hand moves toward the user
  servo.wait_ticks(3);
  r = servo.reading();
  EXPECT_EQ(r.buttons, 0b01u);
  EXPECT_GT(r.velocity.z(), 0.0) << r.velocity.transpose();
}

TEST_F(TouchTest, ForceIsRefusedUntilTheStylusIsInTheInkwell) {
  standin.set_calibration(hd::kCalibrationNeedsManualInput);
  Servo servo;
  auto device = start(servo);
  const Calibration needed = device->calibrate();
  EXPECT_EQ(needed.readiness, Readiness::NeedsOperator);
  EXPECT_NE(needed.message.find("put the stylus in the inkwell"), std::string::npos) << needed.message;
  servo.enable = true;
  servo.fx = 1.0;
  servo.wait_ticks(50);
  EXPECT_EQ(standin.force_output_enabled(), 0);
  EXPECT_EQ(standin.force(), Vec3::Zero());
  standin.set_inkwell(1);
  const Calibration done = device->calibrate();  // the clock runs: inside a scheduler callback
  EXPECT_EQ(done.readiness, Readiness::Ready) << done.message;
  EXPECT_EQ(done.message, "calibration updated (inkwell)");
  servo.wait_ticks(50);
  EXPECT_EQ(standin.force_output_enabled(), 1);
  EXPECT_TRUE(standin.force().isApprox(Vec3(1.0, 0.0, 0.0))) << standin.force().transpose();
}

TEST_F(TouchTest, AnAutomaticallyCalibratingDeviceIsUpdatedWithoutTheOperator) {
  standin.configure("Default Device", "Touch X", 3, hd::kCalibrationAuto, 0.0);
  standin.set_calibration(hd::kCalibrationNeedsUpdate);
  auto device = make_touch_device("");
  device->open();
  const Calibration c = device->calibrate();  // no clock yet: directly, inside a frame of its own
  EXPECT_EQ(c.readiness, Readiness::Ready) << c.message;
  EXPECT_EQ(c.message, "calibration updated (automatic)");
  EXPECT_EQ(standin.frame_violations(), 0);
}

// Each HD error mid-run: the reading of the cycle it comes in carries its fault and is invalid, and
// that cycle's write renders no force; the next clean cycle renders again.
TEST_F(TouchTest, AnHdErrorMidRunZeroesTheForceInTheSameCycle) {
  const std::pair<hd::HDerror, uint32_t> cases[] = {
      {hd::kWarmMotors, kHardwareOverheat},
      {hd::kExceededMaxVelocity, kHardwareVelocityExceeded},
      {hd::kExceededMaxForce, kHardwareForceExceeded},
      {hd::kCommError, kHardwareCommunication},
  };  // HD_DEVICE_FAULT (the device lost) is AnUnpluggedDeviceIsReopenedWhenItAnswersAgain's
  Servo servo;
  auto device = start(servo);
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  servo.fy = 1.5;
  servo.wait_ticks(20);
  for (const auto& [code, fault] : cases) {
    {
      std::lock_guard<std::mutex> lock(servo.mutex);
      servo.cycles.clear();
    }
    standin.inject_error(code, 0, 1);
    servo.wait_ticks(20);
    std::lock_guard<std::mutex> lock(servo.mutex);
    std::size_t faulted = 0;
    for (std::size_t i = 0; i + 1 < servo.cycles.size(); ++i) {
      if (servo.cycles[i].faults == 0) continue;
      ++faulted;
      EXPECT_EQ(servo.cycles[i].faults, fault) << "HD error 0x" << std::hex << code;
      EXPECT_EQ(servo.cycles[i + 1].previous_output, 0.0) << "the faulted cycle rendered a force";
      if (i + 2 < servo.cycles.size()) {
        EXPECT_NEAR(servo.cycles[i + 2].previous_output, 1.5, 1e-12);
      }
    }
    EXPECT_EQ(faulted, 1u) << "HD error 0x" << std::hex << code;
  }
}

// Waits (bounded) until the servo's last reading satisfies `done`; that reading.
template <class Done>
HardwareReading wait_reading(Servo& servo, Done done) {
  HardwareReading r = servo.reading();
  for (int i = 0; i < 3000 && !done(r); ++i) {
    std::this_thread::sleep_for(1ms);
    r = servo.reading();
  }
  return r;
}

TEST_F(TouchTest, AnUnpluggedDeviceIsReopenedWhenItAnswersAgain) {
  Servo servo;
  auto device = start(servo);
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  servo.fy = 1.5;
  servo.wait_ticks(20);
  ASSERT_NEAR(standin.force().norm(), 1.5, 1e-12);
  {
    std::lock_guard<std::mutex> lock(servo.mutex);
    servo.cycles.clear();
  }
  // Unplugged: the first faulted cycle renders nothing, every later one is faulted and renders
  // nothing; a communication error that persists becomes "lost" (kHardwareLost).
  standin.unplug(1);
  const HardwareReading lost =
      wait_reading(servo, [](const HardwareReading& r) { return (r.faults & kHardwareLost) != 0; });
  EXPECT_FALSE(lost.valid);
  servo.wait_ticks(50);
  servo.enable = false;
  EXPECT_EQ(servo.reading().faults, static_cast<uint32_t>(kHardwareLost));
  {
    std::lock_guard<std::mutex> lock(servo.mutex);
    std::size_t first = 0;
    while (first < servo.cycles.size() && servo.cycles[first].faults == 0) ++first;
    ASSERT_LT(first + 1, servo.cycles.size());
    EXPECT_NE(servo.cycles[first].faults & kHardwareCommunication, 0u);
    for (std::size_t i = first; i + 1 < servo.cycles.size(); ++i) {
      EXPECT_NE(servo.cycles[i].faults, 0u) << "cycle " << i;
      EXPECT_EQ(servo.cycles[i + 1].previous_output, 0.0) << "cycle " << i;
    }
  }
  EXPECT_FALSE(servo.reading().valid);

  // Plugged back: reopened (a new handle), force off until enabled again, then rendered again.
  standin.unplug(0);
  const HardwareReading back = wait_reading(servo, [](const HardwareReading& r) { return r.valid; });
  ASSERT_TRUE(back.valid) << describe_hardware_faults(back.faults);
  EXPECT_EQ(standin.is_open(), 1);
  servo.wait_ticks(10);
  EXPECT_EQ(standin.force_output_enabled(), 0);
  EXPECT_EQ(standin.force().norm(), 0.0);
  servo.enable = true;
  servo.wait_ticks(10);
  EXPECT_NEAR(standin.force().norm(), 1.5, 1e-12);
  EXPECT_EQ(standin.frame_violations(), 0);
  device->close();
  EXPECT_EQ(standin.is_open(), 0);
}

TEST_F(TouchTest, ADeviceBackButUncalibratedSaysSoUntilTheStylusIsInTheInkwell) {
  Servo servo;
  auto device = start(servo);
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  servo.fy = 1.0;
  standin.inject_error(hd::kDeviceFault, 0, 1);  // the device gone at once
  const HardwareReading lost =
      wait_reading(servo, [](const HardwareReading& r) { return (r.faults & kHardwareLost) != 0; });
  EXPECT_FALSE(lost.valid);
  // It lost its calibration meanwhile (powered off and on): back, its readings say so, force off.
  standin.set_calibration(hd::kCalibrationNeedsManualInput);
  const HardwareReading back = wait_reading(
      servo, [](const HardwareReading& r) { return (r.faults & kHardwareLost) == 0 && r.faults != 0; });
  EXPECT_EQ(back.faults, static_cast<uint32_t>(kHardwareNotCalibrated));
  EXPECT_FALSE(back.valid);
  servo.wait_ticks(20);
  EXPECT_EQ(standin.force_output_enabled(), 0);
  EXPECT_EQ(standin.force().norm(), 0.0);
  // The stylus in the inkwell: calibrated again, valid readings, force.
  standin.set_inkwell(1);
  const HardwareReading ready = wait_reading(servo, [](const HardwareReading& r) { return r.valid; });
  ASSERT_TRUE(ready.valid) << describe_hardware_faults(ready.faults);
  servo.wait_ticks(10);
  EXPECT_NEAR(standin.force().norm(), 1.0, 1e-12);
  device->close();
}

TEST_F(TouchTest, ANonFiniteWrenchRendersNothing) {
  Servo servo;
  auto device = start(servo);
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  servo.fz = std::nan("");
  servo.wait_ticks(20);
  EXPECT_EQ(standin.force(), Vec3::Zero());
}

// The servo loop's last zero wrench comes after the clock stopped: it goes in a frame of its own.
TEST_F(TouchTest, AWriteWithTheClockStoppedGoesInAFrameOfItsOwn) {
  auto device = make_touch_device("");
  device->open();
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  device->enable_force(true);
  device->write(Vec3(0.0, 0.5, 0.0), Vec3::Zero());
  EXPECT_TRUE(standin.force().isApprox(Vec3(0.0, 0.5, 0.0))) << standin.force().transpose();
  device->write(Vec3::Zero(), Vec3::Zero());
  EXPECT_EQ(standin.force(), Vec3::Zero());
  EXPECT_EQ(standin.frame_violations(), 0);
}

// The servo thread's calls allocate nothing (the stand-in's functions allocate nothing either).
TEST_F(TouchTest, ReadAndWriteAllocateNothing) {
  standin.configure("Default Device", "PHANToM Premium 1.5 6DOF", 6, hd::kCalibrationEncoderReset, 188.0);
  auto device = make_touch_device("");
  device->open();
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  device->enable_force(true);
  (void)device->read();
  device->write(Vec3(0.1, 0.2, 0.3), Vec3(1.0, 2.0, 3.0));
  const std::size_t before = test::allocation_count();
  double sum = 0.0;
  for (int i = 0; i < 1000; ++i) {
    sum += device->read().pose.p.norm();
    device->write(Vec3(0.1, 0.2, 0.3), Vec3(1.0, 2.0, 3.0));
  }
  EXPECT_EQ(test::allocation_count(), before);
  EXPECT_TRUE(std::isfinite(sum));
  EXPECT_TRUE(standin.torque().isApprox(Vec3(1.0, 2.0, 3.0)));
}

TEST_F(TouchTest, CloseSwitchesTheForceOffStopsTheClockAndReleasesTheDevice) {
  Servo servo;
  auto device = start(servo);
  ASSERT_EQ(device->calibrate().readiness, Readiness::Ready);
  servo.enable = true;
  servo.fx = 1.0;
  servo.wait_ticks(20);
  ASSERT_EQ(standin.force_output_enabled(), 1);
  device->close();
  EXPECT_EQ(standin.force_output_enabled(), 0);
  EXPECT_EQ(standin.force(), Vec3::Zero());
  EXPECT_EQ(standin.is_open(), 0);
  const int stopped_at = servo.ticks.load();
  std::this_thread::sleep_for(20ms);
  EXPECT_EQ(servo.ticks.load(), stopped_at);
  device->close();                 // twice is safe
  make_touch_device("")->close();  // and never opened
}

TEST_F(TouchTest, TheSurveyNamesTheLibraryAndTheDefaultDevice) {
  HardwareSurvey survey = survey_touch();
  EXPECT_EQ(survey.backend, "touch");
  ASSERT_TRUE(survey.sdk.path.has_value()) << survey.sdk.describe();
  EXPECT_EQ(survey.version, "3.4.0");
  ASSERT_EQ(survey.devices.size(), 1u) << survey.problem;
  EXPECT_EQ(survey.devices[0].model, "Touch");
  EXPECT_EQ(standin.is_open(), 0) << "the survey closes what it opened";
  setenv("CARIESIM_HD_LIBRARY", "/nonexistent/libHD.so", 1);
  survey = survey_touch();
  EXPECT_FALSE(survey.sdk.path.has_value());
  EXPECT_TRUE(survey.devices.empty());
  EXPECT_NE(survey.problem.find("not found"), std::string::npos) << survey.problem;
  EXPECT_NE(survey.install.find("OpenHaptics"), std::string::npos);
}

// Through the factory's `touch` (a HapticDevice with the default profile): turning the stylus about
// HD's y (up) turns the tool as much about the scene's z (up), moving it toward the user moves the
// tool toward the operator (scene -y), and button 1 is the default profile's mark mild.
TEST_F(TouchTest, UnpluggedAndBackTheFactorysTouchReturnsForceThroughTheGateAndTheRamp) {
  auto device = make_device("touch", DeviceOptions{});
  device->start();
  const auto* haptic = dynamic_cast<const HapticDevice*>(device.get());
  ASSERT_NE(haptic, nullptr);
  double t = 0.0;
  const auto cycle = [&](const Vec3& force) {
    t += 0.001;
    const DeviceState state = device->read(t);
    device->write(force, Vec3::Zero());
    return state;
  };
  cycle(Vec3::Zero());
  t = 1.0;
  cycle(Vec3(0.0, 0.0, 2.0));
  ASSERT_TRUE(haptic->status().force_enabled);
  ASSERT_NEAR(standin.force().norm(), 2.0, 1e-9);

  // Unplugged: no force from then on; once lost, the force switch is off and the panel says lost.
  standin.unplug(1);
  for (int i = 0; i < 3000 && (haptic->status().faults & kHardwareLost) == 0; ++i) {
    // The first read precedes any frame since the cable went (the write's frame raises the error).
    const DeviceState state = cycle(Vec3(0.0, 0.0, 2.0));
    if (i > 0) {
      EXPECT_FALSE(state.valid) << "cycle " << i;
    }
    EXPECT_EQ(standin.force().norm(), 0.0);
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_FALSE(cycle(Vec3(0.0, 0.0, 2.0)).valid);
  EXPECT_EQ(haptic->status().faults, static_cast<uint32_t>(kHardwareLost));
  EXPECT_FALSE(haptic->status().force_enabled);

  // Back: valid readings; a large force waits for the gate, a small one passes it and ramps in.
  standin.unplug(0);
  bool valid = false;
  for (int i = 0; i < 3000 && !valid; ++i) {
    valid = cycle(Vec3(0.0, 0.0, 2.0)).valid;
    std::this_thread::sleep_for(1ms);
  }
  ASSERT_TRUE(valid);
  EXPECT_EQ(haptic->status().faults, 0u);
  EXPECT_FALSE(haptic->status().force_enabled);
  EXPECT_EQ(standin.force().norm(), 0.0);
  cycle(Vec3(0.0, 0.0, 0.2));
  EXPECT_TRUE(haptic->status().force_enabled);
  EXPECT_LT(standin.force().norm(), 0.01);
  t += 0.25;
  cycle(Vec3(0.0, 0.0, 2.0));
  EXPECT_NEAR(standin.force().norm(), 1.0, 0.02);
  device->stop();
  EXPECT_EQ(standin.is_open(), 0);
}

TEST_F(TouchTest, TheFactorysTouchMapsHdsFrameOntoTheScene) {
  DeviceOptions options;
  options.home = Pose{Vec3(5.0, 6.0, 7.0), Quat(Eigen::AngleAxisd(0.3, Vec3(0.0, 1.0, 0.0)))};
  auto device = make_device("touch", options);
  device->start();
  EXPECT_EQ(device->info().name, "touch");
  EXPECT_NE(device->info().description.find("Touch #220-00042"), std::string::npos)
      << device->info().description;
  const DeviceState home = device->read(0.0);
  ASSERT_TRUE(home.valid);
  EXPECT_TRUE(home.pose.p.isApprox(options.home.p, 1e-9)) << home.pose.p.transpose();
  EXPECT_LT(home.pose.q.angularDistance(options.home.q), 1e-9);
  const Quat rest(Eigen::AngleAxisd(-std::numbers::pi / 2.0, Vec3::UnitX()));
  const Quat turned = Quat(Eigen::AngleAxisd(0.5, Vec3::UnitY())) * rest;
  standin.set_orientation(turned.w(), turned.x(), turned.y(), turned.z());
  standin.place(0.0, 0.0, 10.0);
  standin.set_buttons(0b10);
  const DeviceState moved = device->read(0.001);
  ASSERT_TRUE(moved.valid);
  const Quat expected = Quat(Eigen::AngleAxisd(0.5, Vec3::UnitZ())) * options.home.q;
  EXPECT_LT(moved.pose.q.angularDistance(expected), 1e-9);
  EXPECT_TRUE(moved.pose.p.isApprox(options.home.p + Vec3(0.0, -10.0, 0.0), 1e-9))
      << moved.pose.p.transpose();
  EXPECT_EQ(moved.buttons, 0b10u);
  EXPECT_EQ(moved.actions, static_cast<uint32_t>(kActionMarkMild));
  device->stop();
  EXPECT_EQ(standin.is_open(), 0);
}

}  // namespace
}  // namespace cariesim
