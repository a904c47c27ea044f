// `cariesim servo --device haply:URL` against the Inverse Service stand-in running in this test's
// process (tests/device/standins/haply): the hand presses the simulated Inverse3's cursor down onto
// the friction block, the servo loop renders the contact through the backend, and the service receives
// a force pushing up along the device's own z axis; at the end the force is zero and the WebSocket
// closed. The service going away mid-run ends the run cleanly (the record closed); a service of another
// version is refused by name before the loop starts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <thread>

#include "apps/apps_support.hpp"
#include "cariesim/record/recorder.hpp"
#include "servo/servo_support.hpp"
#include "standins/haply/inverse_service.hpp"
#include "support/command.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

class HaplyCommand : public test::ScratchTest {
 protected:
  HaplyCommand() : ScratchTest("cariesim_haply_cmd_") {}
};

TEST_F(HaplyCommand, ServoRendersThePressOnTheStandIn) {
  test::InverseService service;
  // The cursor at the workspace centre (the tool home, by the default profile), the hand pressing
  // down with 0.3 N: the cursor sinks onto the block until the contact force holds it.
  service.place_cursor(Vec3(0.0, 0.1, 0.1));
  service.push_hand(Vec3(0.0, 0.0, -0.3));
  const fs::path db = dir_ / "haply.db";
  const test::CommandResult r =
      test::run_cariesim("servo --scene friction-block --device 'haply:" + service.url() +
                         "' --duration 2 --no-realtime --record '" + db.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("device haply: torque_dropped="));
  const Recording rec = load_recording(db);
  EXPECT_GT(rec.samples.size(), 1000u);
  EXPECT_GT(service.commands(), 1000u);
  // The cursor came down onto the block (its top 0 mm, the home above it), and the block holds the
  // hand: the last force before close pushes up along the device's +z with the hand's 0.3 N.
  EXPECT_LT(service.position().z(), 0.1 - test::friction_block().tool_home.p.z() / 1000.0 + 0.001);
  const Vec3 held = service.last_nonzero_force();
  EXPECT_NEAR(held.z(), 0.3, 0.05) << held.transpose();
  EXPECT_LT(std::hypot(held.x(), held.y()), 0.05) << held.transpose();
  EXPECT_GT(service.peak_force().norm(), 0.2);
  EXPECT_EQ(service.last_force(), Vec3::Zero());
  EXPECT_EQ(service.open_connections(), 0);
}

TEST_F(HaplyCommand, TheServiceGoingAwayEndsTheRunCleanly) {
  test::InverseService service;
  service.place_cursor(Vec3(0.0, 0.1, 0.1));
  const fs::path db = dir_ / "lost.db";
  test::CommandResult r;
  std::thread servo([&] {
    r = test::run_cariesim("servo --scene friction-block --device 'haply:" + service.url() +
                           "' --duration 60 --no-realtime --record '" + db.string() + "'");
  });
  // Once the loop exchanges with the service, the service stops.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (service.commands() < 500 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  service.go_away();
  servo.join();
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("servo: the device was lost ("));
  EXPECT_THAT(r.err, HasSubstr("device lost); ending the run"));
  const Recording rec = load_recording(db);
  EXPECT_FALSE(rec.info.ended_at.empty());
  EXPECT_GT(rec.samples.size(), 100u);
}

TEST_F(HaplyCommand, AnotherServiceVersionIsRefusedByName) {
  test::InverseService service;
  service.set_version("3.0.7.0");
  const test::CommandResult r = test::run_cariesim(
      "servo --scene friction-block --device 'haply:" + service.url() + "' --duration 1 --no-realtime");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("Haply Inverse Service 3.0.7.0 is too old"));
  EXPECT_EQ(service.connections(), 0u);
}

// A crash (here SIGSEGV from outside, as a fault on any thread would raise it) while the hand
// presses on the block: the program's fatal-signal handler stops every force (request_force_stop)
// and gives the servo thread a few cycles before the signal takes its course, so the last force the
// device received is zero, not the press's 0.3 N.
TEST_F(HaplyCommand, ACrashLeavesTheDeviceWithNoForce) {
  test::InverseService service;
  service.place_cursor(Vec3(0.0, 0.1, 0.1));
  service.push_hand(Vec3(0.0, 0.0, -0.3));
  const fs::path db = dir_ / "crash.db";
  test::CommandResult r;
  std::thread servo([&] {
    r = test::run_cariesim("servo --scene friction-block --device 'haply:" + service.url() +
                           "' --duration 60 --no-realtime --quiet --record '" + db.string() + "'");
  });
  // Pressing: the service receives the contact's force.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (service.last_force().z() < 0.2 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GT(service.last_force().z(), 0.2) << "the press never reached the device";
  const pid_t pid = test::find_process(CARIESIM_EXE, db.string());
  EXPECT_GT(pid, 0) << "servo is not running";
  if (pid > 0) ::kill(pid, SIGSEGV);
  servo.join();
  EXPECT_NE(r.status, 0) << r.err;  // it did crash
  EXPECT_EQ(service.last_force(), Vec3::Zero()) << service.last_force().transpose();
}

}  // namespace
}  // namespace cariesim
