// The Haply backend (make_haply_device) against the Inverse Service stand-in
// (tests/device/standins/haply): the test thread plays the servo thread. A force along each of the
// device's axes reaches the service in N along that axis; the cursor comes back in mm and the VerseGrip's
// orientation and buttons as they are; force stays zero until enabled and after close; another
// service version, no Inverse3 and no service each refuse to open with their message; slow answers
// make the reading stale (a communication fault), the service going away makes it lost, and the
// backend reconnects when the service is back; the servo-thread calls allocate nothing. Through the
// factory's `haply:URL` (a HapticDevice): the workspace centre maps to the tool home, the grip's turn
// to the tool's, buttons to actions, the force enables, ramps in and reaches the service, a stale
// reading zeroes it, and stop switches it off.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <thread>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/device/factory.hpp"
#include "cariesim/device/hardware_backends.hpp"
#include "standins/haply/inverse_service.hpp"
#include "support/alloc_counter.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;

// Polls `done` every ms for up to `seconds`, reading the device each time (as the servo loop would).
bool until(HardwareDevice& device, const std::function<bool(const HardwareReading&)>& done,
           double seconds = 3.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (done(device.read())) return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

// Polls a condition on the stand-in.
bool until(const std::function<bool()>& done, double seconds = 3.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

// What opening `url` threw ("" when it opened).
std::string open_error(const std::string& url) {
  auto device = make_haply_device(url);
  try {
    device->open();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(HaplyDevice, OpensWithWhatTheServiceTells) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  const HardwareInfo info = device->info();
  EXPECT_EQ(info.backend, "haply");
  EXPECT_EQ(info.model, "Inverse3");
  EXPECT_EQ(info.serial, "049D");
  EXPECT_THAT(info.sdk, HasSubstr("Haply Inverse Service 3.2.1.0"));
  EXPECT_EQ(info.dof_in, 6);
  EXPECT_EQ(info.dof_out, 3);
  EXPECT_EQ(info.buttons, 3);
  EXPECT_GT(info.max_force, 0.0);
  EXPECT_TRUE(info.axes.isApprox(Quat::Identity()));
  // The stand-in answers at 1 kHz at most; the rate is what the exchange measured.
  EXPECT_GT(info.rate_hz, 200.0);
  EXPECT_LT(info.rate_hz, 1100.0);
  EXPECT_EQ(device->calibrate().readiness, Readiness::Ready);
  EXPECT_EQ(service.open_connections(), 1);
}

TEST(HaplyDevice, ForceAlongEachAxisReachesTheServiceInNewtons) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  device->enable_force(true);
  for (int axis = 0; axis < 3; ++axis) {
    const Vec3 force = Vec3::Unit(axis) * -1.5;   // N, a press along the device's own axis
    device->write(force, Vec3(0.0, 0.0, 100.0));  // a torque the 3-DoF device drops
    ASSERT_TRUE(until([&] { return (service.last_force() - force).norm() < 1e-9; })) << "axis " << axis;
  }
  EXPECT_EQ(service.bad_commands(), 0u);
}

TEST(HaplyDevice, CursorComesBackInMillimetresAndMovesWithTheHand) {
  test::InverseService service;
  service.place_cursor(Vec3(0.01, 0.12, 0.05));  // m
  auto device = make_haply_device(service.url());
  device->open();
  HardwareReading r;
  ASSERT_TRUE(until(*device, [&](const HardwareReading& x) {
    r = x;
    return x.valid;
  }));
  EXPECT_TRUE(r.pose.p.isApprox(Vec3(10.0, 120.0, 50.0), 1e-9)) << r.pose.p.transpose();
  // A hand pushing along +x moves the cursor along +x (mm), with a positive velocity (mm/s).
  service.push_hand(Vec3(1.0, 0.0, 0.0));
  ASSERT_TRUE(until(*device, [&](const HardwareReading& x) {
    r = x;
    return x.valid && x.pose.p.x() > 12.0;
  }));
  EXPECT_GT(r.velocity.x(), 0.0);
  EXPECT_NEAR(r.pose.p.y(), 120.0, 1e-6);
  EXPECT_NEAR(r.pose.p.x(), service.position().x() * 1000.0, 20.0);
}

TEST(HaplyDevice, GripOrientationAndButtons) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  const Quat turned(Eigen::AngleAxisd(0.6, Vec3(1.0, 2.0, 0.5).normalized()));
  service.set_orientation(turned);
  service.set_buttons(0b101);
  HardwareReading r;
  ASSERT_TRUE(until(*device, [&](const HardwareReading& x) {
    r = x;
    return x.valid && x.buttons == 0b101u;
  }));
  EXPECT_NEAR(r.pose.q.angularDistance(turned), 0.0, 1e-9);
  service.set_buttons(0b010);
  EXPECT_TRUE(until(*device, [](const HardwareReading& x) { return x.buttons == 0b010u; }));
}

TEST(HaplyDevice, WithoutAGripPositionOnly) {
  test::InverseServiceOptions options;
  options.grip = false;
  test::InverseService service(options);
  auto device = make_haply_device(service.url());
  device->open();
  EXPECT_EQ(device->info().dof_in, 3);
  EXPECT_EQ(device->info().buttons, 0);
  service.set_orientation(Quat(Eigen::AngleAxisd(0.5, Vec3::UnitZ())));
  ASSERT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
  EXPECT_TRUE(device->read().pose.q.isApprox(Quat::Identity()));
}

TEST(HaplyDevice, ForceIsZeroUntilEnabledAndAfterDisabling) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  device->write(Vec3(0.0, 0.0, 2.0), Vec3::Zero());
  const uint64_t before = service.commands();
  ASSERT_TRUE(until([&] { return service.commands() > before + 20; }));
  EXPECT_EQ(service.last_force(), Vec3::Zero());
  device->enable_force(true);
  ASSERT_TRUE(until([&] { return service.last_force().z() == 2.0; }));
  device->enable_force(false);
  EXPECT_TRUE(until([&] { return service.last_force() == Vec3::Zero(); }));
}

TEST(HaplyDevice, CloseSwitchesTheForceOffAndLeaves) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  device->enable_force(true);
  device->write(Vec3(1.0, -2.0, 0.5), Vec3::Zero());
  ASSERT_TRUE(until([&] { return service.last_force().y() == -2.0; }));
  device->close();
  EXPECT_EQ(service.last_force(), Vec3::Zero());
  EXPECT_TRUE(until([&] { return service.open_connections() == 0; }));
  device->close();                            // twice is fine
  make_haply_device(service.url())->close();  // and never opened
}

TEST(HaplyDevice, OtherVersionsAreRefusedByName) {
  test::InverseService service;
  service.set_version("3.0.7.0");
  const std::string old = open_error(service.url());
  EXPECT_THAT(old, HasSubstr("Haply Inverse Service 3.0.7.0 is too old"));
  EXPECT_THAT(old, HasSubstr("cariesim speaks the 3.1 JSON format"));
  service.set_version("3.5.0.0");
  EXPECT_THAT(open_error(service.url()), HasSubstr("3.5.0.0 is newer than cariesim knows"));
  EXPECT_EQ(service.connections(), 0u);  // refused before the WebSocket
}

TEST(HaplyDevice, NoInverse3AndNoServiceGiveTheirMessage) {
  test::InverseService service;
  service.set_inverse3(false);
  EXPECT_THAT(open_error(service.url()), HasSubstr("no Inverse3 attached"));
  service.go_away();
  const std::string gone = open_error(service.url());
  EXPECT_THAT(gone, HasSubstr("connection refused: the service is not running"));
  EXPECT_THAT(gone, HasSubstr("systemctl start haply-inverse-service"));
}

TEST(HaplyDevice, SlowAnswersAreStaleAndRecover) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  device->enable_force(true);
  ASSERT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
  service.set_answer_delay(0.2);  // s: far beyond a few 1 ms periods
  HardwareReading r;
  ASSERT_TRUE(until(*device, [&](const HardwareReading& x) {
    r = x;
    return !x.valid;
  }));
  EXPECT_EQ(r.faults, static_cast<uint32_t>(kHardwareCommunication));
  service.set_answer_delay(0.0);
  EXPECT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
}

TEST(HaplyDevice, DroppedConnectionIsLostThenReconnects) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  device->enable_force(true);
  device->write(Vec3(0.0, 1.0, 0.0), Vec3::Zero());
  ASSERT_TRUE(until([&] { return service.last_force().y() == 1.0; }));
  service.drop_connections();
  HardwareReading r;
  ASSERT_TRUE(until(*device, [&](const HardwareReading& x) {
    r = x;
    return !x.valid;
  }));
  EXPECT_NE(r.faults & (kHardwareLost | kHardwareCommunication), 0u);
  ASSERT_TRUE(until([&] { return service.connections() == 2u; }));
  EXPECT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
}

TEST(HaplyDevice, ServiceGoneIsLostAndBackIsResumed) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  service.go_away();
  HardwareReading r;
  ASSERT_TRUE(until(*device, [&](const HardwareReading& x) {
    r = x;
    return (x.faults & kHardwareLost) != 0;
  }));
  EXPECT_FALSE(r.valid);
  std::this_thread::sleep_for(600ms);  // a few reconnection attempts against a closed port
  EXPECT_FALSE(device->read().valid);
  service.come_back();
  EXPECT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
}

TEST(HaplyDevice, DeviceUnpluggedMidRunIsLost) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  service.set_inverse3(false);
  EXPECT_TRUE(until(*device, [](const HardwareReading& x) { return (x.faults & kHardwareLost) != 0; }));
  service.set_inverse3(true);
  EXPECT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
}

TEST(HaplyDevice, CalibrationNeedsAStreamingService) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  EXPECT_EQ(device->calibrate().readiness, Readiness::Failed);  // not open
  device->open();
  EXPECT_EQ(device->calibrate().readiness, Readiness::Ready);
  service.go_away();
  ASSERT_TRUE(until([&] { return device->calibrate().readiness == Readiness::NeedsOperator; }));
  EXPECT_THAT(device->calibrate().message, HasSubstr("device lost"));
  service.come_back();
  EXPECT_TRUE(until([&] { return device->calibrate().readiness == Readiness::Ready; }));
}

// The servo loop's side of a HapticDevice: read at `now`, then write the force.
struct Servo {
  Device& device;
  double start = static_cast<double>(monotonic_ns()) * 1e-9;
  DeviceState cycle(const Vec3& force) {
    const DeviceState state = device.read(static_cast<double>(monotonic_ns()) * 1e-9 - start);
    device.write(force, Vec3::Zero());
    return state;
  }
  // Cycles every ms writing `force` until `done` (at most `seconds`).
  bool until(const Vec3& force, const std::function<bool(const DeviceState&)>& done, double seconds = 3.0) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      if (done(cycle(force))) return true;
      std::this_thread::sleep_for(1ms);
    }
    return false;
  }
};

TEST(HaplyHapticDevice, MapsRendersAndSwitchesOff) {
  test::InverseService service;
  service.place_cursor(Vec3(0.0, 0.1, 0.1));  // m: the centre of the backend's workspace
  DeviceOptions options;
  options.home.p = Vec3(5.0, -3.0, 12.0);
  std::unique_ptr<Device> device = make_device("haply:" + service.url(), options);
  device->start();
  EXPECT_EQ(device->info().name, "haply");
  Servo servo{*device};
  DeviceState s;
  ASSERT_TRUE(servo.until(Vec3::Zero(), [&](const DeviceState& x) {
    s = x;
    return x.valid;
  }));
  EXPECT_TRUE(s.pose.p.isApprox(options.home.p, 1e-6)) << s.pose.p.transpose();
  EXPECT_NEAR(s.pose.q.angularDistance(options.home.q), 0.0, 1e-9);

  // The hand 10 mm to the right and the grip turned 0.3 rad about z: the tool follows.
  service.place_cursor(Vec3(0.01, 0.1, 0.1));
  service.set_orientation(Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ())));
  ASSERT_TRUE(servo.until(Vec3::Zero(), [&](const DeviceState& x) {
    s = x;
    return x.valid && std::abs(x.pose.p.x() - 15.0) < 1e-6 && x.pose.q.angularDistance(options.home.q) > 0.29;
  }));
  EXPECT_NEAR(s.pose.q.angularDistance(options.home.q), 0.3, 1e-9);

  // Button b marks mild (the default profile).
  service.set_buttons(0b010);
  ASSERT_TRUE(
      servo.until(Vec3::Zero(), [](const DeviceState& x) { return (x.actions & kActionMarkMild) != 0; }));
  service.set_buttons(0);

  // A press: the force enables (the tool out of contact), ramps in and reaches the service in N.
  const Vec3 press(0.0, 0.0, -2.0);
  ASSERT_TRUE(
      servo.until(press, [&](const DeviceState&) { return (service.last_force() - press).norm() < 1e-9; }));

  // A stale reading (slow answers): the force written is zero in that very cycle.
  service.set_answer_delay(0.2);
  ASSERT_TRUE(servo.until(press, [](const DeviceState& x) { return !x.valid; }));
  service.set_answer_delay(0.0);
  EXPECT_TRUE(until([&] { return service.last_force() == Vec3::Zero(); }));

  ASSERT_TRUE(
      servo.until(press, [&](const DeviceState&) { return (service.last_force() - press).norm() < 1e-9; }));
  device->stop();
  EXPECT_EQ(service.last_force(), Vec3::Zero());
}

// CARIESIM_HAPLY_URL set for one test, unset after it.
class HaplyUrlVariable : public ::testing::Test {
 protected:
  void set(const std::string& url) { ::setenv("CARIESIM_HAPLY_URL", url.c_str(), 1); }
  void TearDown() override { ::unsetenv("CARIESIM_HAPLY_URL"); }
};

TEST_F(HaplyUrlVariable, SurveyListsTheServiceAndItsInverse3) {
  test::InverseService service;
  set(service.url());
  HardwareSurvey s = survey_haply();
  EXPECT_EQ(s.backend, "haply");
  EXPECT_EQ(s.version, "3.2.1.0");
  EXPECT_EQ(s.sdk.env_var, "CARIESIM_HAPLY_URL");
  ASSERT_TRUE(s.sdk.path.has_value());
  EXPECT_THAT(*s.sdk.path, HasSubstr(service.url().substr(0, service.url().find(','))));
  ASSERT_EQ(s.devices.size(), 1u);
  EXPECT_EQ(s.devices[0].serial, "049D");
  EXPECT_EQ(s.devices[0].dof_in, 6);
  EXPECT_TRUE(s.problem.empty()) << s.problem;
  // A bare `haply` goes where the variable says.
  auto device = make_haply_device("");
  device->open();
  EXPECT_EQ(device->info().serial, "049D");
  device->close();

  service.set_inverse3(false);
  s = survey_haply();
  EXPECT_TRUE(s.devices.empty());
  EXPECT_EQ(s.problem, "no Inverse3 attached to the service");
  service.set_version("3.0.7.0");
  EXPECT_THAT(survey_haply().problem, HasSubstr("3.0.7.0 is too old"));
  service.go_away();
  s = survey_haply();
  EXPECT_FALSE(s.sdk.path.has_value());
  ASSERT_EQ(s.sdk.tried.size(), 1u);
  EXPECT_THAT(s.sdk.tried[0].second, HasSubstr("connection refused"));
  EXPECT_THAT(s.install, HasSubstr("haply-inverse-service"));
  set("localhost:1");
  EXPECT_THAT(survey_haply().problem, HasSubstr("expected http://HOST:PORT"));
}

TEST(HaplyDevice, ServoThreadCallsAllocateNothing) {
  test::InverseService service;
  auto device = make_haply_device(service.url());
  device->open();
  ASSERT_TRUE(until(*device, [](const HardwareReading& x) { return x.valid; }));
  // Slow answers park the I/O thread and the stand-in in their waits, so the count is the test's.
  service.set_answer_delay(0.5);
  std::this_thread::sleep_for(50ms);
  const std::size_t before = test::allocation_count();
  for (int i = 0; i < 1000; ++i) {
    (void)device->read();
    device->write(Vec3(0.0, 0.0, 0.001 * i), Vec3::Zero());
    device->enable_force(i % 2 == 0);
  }
  EXPECT_EQ(test::allocation_count(), before);
  service.set_answer_delay(0.0);
}

}  // namespace
}  // namespace cariesim
