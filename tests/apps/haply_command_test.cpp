// `cariesim servo --device haply:URL` against the Inverse Service stand-in running in this test's
// process (tests/device/standins/haply): the hand presses the simulated Inverse3's cursor down onto
// the friction block, the servo loop renders the contact through the backend, and the service receives
// a force pushing up along the device's own z axis; at the end the force is zero and the WebSocket
// closed. A service of another version is refused by name before the loop starts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "apps/apps_support.hpp"
#include "cariesim/record/recorder.hpp"
#include "servo/servo_support.hpp"
#include "standins/haply/inverse_service.hpp"

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

TEST_F(HaplyCommand, AnotherServiceVersionIsRefusedByName) {
  test::InverseService service;
  service.set_version("3.0.7.0");
  const test::CommandResult r = test::run_cariesim(
      "servo --scene friction-block --device 'haply:" + service.url() + "' --duration 1 --no-realtime");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("Haply Inverse Service 3.0.7.0 is too old"));
  EXPECT_EQ(service.connections(), 0u);
}

}  // namespace
}  // namespace cariesim
