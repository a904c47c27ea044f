// `cariesim servo --device touch` end to end over the stand-in libHD.so (tests/device/standins/hd),
// its hand tracing a circle (CARIESIM_STANDIN_HD=circle): the servo loop runs clocked by HD's
// scheduler, the Touch's force limit in force, and reports the device's counters; with no OpenHaptics library
// the command fails naming what it tried and what to install. The Touch unplugged mid-run
// (CARIESIM_STANDIN_HD=circle,unplug-at-1s) ends the run cleanly, its record closed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "apps/apps_support.hpp"
#include "cariesim/record/recorder.hpp"
#include "servo/servo_support.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;

TEST(TouchCommand, ServoRunsClockedByTheStandinsScheduler) {
  const test::CommandResult r = test::run_cariesim(
      "servo --scene friction-block --device touch --duration 0.5 --no-realtime",
      std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD + " CARIESIM_STANDIN_HD=circle");
  ASSERT_EQ(r.status, 0) << r.err;
  // The Touch's nominal 3.3 N tightened the scene's force limit (the device announced its limits).
  EXPECT_THAT(r.err, HasSubstr("limits: 3.3 N, "));
  EXPECT_THAT(r.err, HasSubstr("real-time: clocked by the device's scheduler at 1000 Hz"));
  EXPECT_THAT(r.err, HasSubstr("device touch: torque_dropped="));
}

class TouchUnplugged : public test::ScratchTest {
 protected:
  TouchUnplugged() : ScratchTest("cariesim_touch_cmd_") {}
};

TEST_F(TouchUnplugged, UnpluggedMidRunTheRunEndsCleanlyWithItsRecord) {
  const std::filesystem::path db = dir_ / "unplugged.db";
  const auto started = std::chrono::steady_clock::now();
  const test::CommandResult r = test::run_cariesim(
      "servo --scene friction-block --device touch --duration 60 --no-realtime --record '" + db.string() +
          "'",
      std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD + " CARIESIM_STANDIN_HD=circle,unplug-at-1s");
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("servo: the device was lost ("));
  EXPECT_THAT(r.err, HasSubstr("device lost); ending the run"));
  EXPECT_LT(took, 30.0) << "the run went on for its whole duration";
  const Recording rec = load_recording(db);
  EXPECT_FALSE(rec.info.ended_at.empty());
  EXPECT_GT(rec.samples.size(), 500u);
}

TEST(TouchCommand, WithoutOpenHapticsTheCommandSaysWhatItTriedAndWhatToInstall) {
  const test::CommandResult r = test::run_cariesim("servo --scene friction-block --device touch --quiet",
                                                   "CARIESIM_HD_LIBRARY=/nonexistent/libHD.so");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err,
              HasSubstr("device spec 'touch': OpenHaptics HD: not found (tried /nonexistent/libHD.so"));
  EXPECT_THAT(r.err, HasSubstr("install 3D Systems' OpenHaptics"));
}

}  // namespace
}  // namespace cariesim
