// `cariesim servo --device fd`: the servo loop driving the stand-in Force Dimension SDK
// (tests/device/standins/fd/, loaded through CARIESIM_FD_LIBRARY) whose hand circles (5 mm, 1 s):
// the device opens, homes when it must, enables its force and ends cleanly; a missing SDK is named.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "apps/apps_support.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;

const std::string kStandIn = std::string("CARIESIM_FD_LIBRARY=") + CARIESIM_STANDIN_FD;
constexpr const char* kServo =
    "servo --scene friction-block --device fd --duration 1.5 --no-realtime --no-standby";

TEST(FdServo, TheServoLoopDrivesTheStandInDevice) {
  const test::CommandResult r = test::run_cariesim(kServo, kStandIn + " CARIESIM_STANDIN_FD_HAND=circle:5:1");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("input ok"));
  // The omega.6's peak force (12 N) tightened the scene's limit (22 N); the counters are the fd device's.
  EXPECT_THAT(r.err, HasSubstr("limits: 12 N"));
  EXPECT_THAT(r.err, HasSubstr("device fd: torque_dropped="));
}

TEST(FdServo, AnUninitialisedDeviceIsHomedFirstAndTheUserIsTold) {
  const test::CommandResult r =
      test::run_cariesim(kServo, kStandIn + " CARIESIM_STANDIN_FD_DEVICES=sigma.7:22002:unhomed");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("homing it robotically now; keep your hands off it"));
  EXPECT_THAT(r.err, HasSubstr("limits: 20 N"));
}

TEST(FdServo, AFalconNotHomedByHandRunsWithoutForceAndSaysHowToHomeIt) {
  const test::CommandResult r =
      test::run_cariesim(kServo, kStandIn + " CARIESIM_STANDIN_FD_DEVICES=falcon:777:unhomed");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("fd Falcon: 3-DoF force"));
  EXPECT_THAT(r.err, HasSubstr("calibration: home the Falcon by hand: pull its grip all the way toward you"));
  EXPECT_THAT(r.err, HasSubstr("limits: 8.9 N"));
}

TEST(FdServo, AMissingSdkAndNoDeviceAreNamed) {
  const test::CommandResult missing =
      test::run_cariesim(kServo, "CARIESIM_FD_LIBRARY=/nonexistent/libdrd.so.3");
  EXPECT_NE(missing.status, 0);
  EXPECT_THAT(missing.err, HasSubstr("device spec 'fd': Force Dimension SDK: not found"));
  const test::CommandResult none = test::run_cariesim(kServo, kStandIn + " CARIESIM_STANDIN_FD_DEVICES=none");
  EXPECT_NE(none.status, 0);
  EXPECT_THAT(none.err, HasSubstr("no Force Dimension device found"));
}

}  // namespace
}  // namespace cariesim
