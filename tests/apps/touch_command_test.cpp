// `cariesim servo --device touch` end to end over the stand-in libHD.so (tests/device/standins/hd),
// its hand tracing a circle (CARIESIM_STANDIN_HD=circle): the servo loop runs clocked by HD's
// scheduler, the Touch's force limit in force, and reports the device's counters; with no OpenHaptics library
// the command fails naming what it tried and what to install.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "apps/apps_support.hpp"

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
