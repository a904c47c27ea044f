// `cariesim servo --device touch` end to end over the stand-in libHD.so (tests/device/standins/hd),
// its hand tracing a circle (CARIESIM_STANDIN_HD=circle): the servo loop runs clocked by HD's
// scheduler, the Touch's force limit in force, and reports the device's counters; with no OpenHaptics library
// the command fails naming what it tried and what to install; a profile's clutch button held while the
// hand moves keeps the recorded tool still, and its release re-indexes without a jump.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "apps/apps_support.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/render/interaction.hpp"

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

class TouchRun : public test::ScratchTest {
 protected:
  TouchRun() : ScratchTest("cariesim_touch_run_") {}
};

// The hand traces a 20 mm circle (one turn in 2 s); button 1, the profile's clutch, is held from 1 s to
// 2 s (half a turn: the hand crosses 40 mm). The recording shows the tool moving before, standing still
// (haptic and graphic) while the clutch is held, and following again after the release from where it
// stood, with no step flagged as a jump and no step larger than the hand's own motion.
TEST_F(TouchRun, TheToolStaysPutWhileTheClutchIsHeldAndDoesNotJumpOnRelease) {
  const std::filesystem::path profile = dir_ / "profile.yaml", db = dir_ / "clutch.db";
  std::ofstream(profile) << "buttons: {1: clutch}\n";
  const test::CommandResult r =
      test::run_cariesim("servo --scene friction-block --device touch --device-profile '" + profile.string() +
                             "' --duration 3 --no-realtime --record '" + db.string() + "'",
                         std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD +
                             " CARIESIM_STANDIN_HD=circle CARIESIM_STANDIN_HD_BUTTONS=1.0:2,2.0:0");
  ASSERT_EQ(r.status, 0) << r.err;
  const Recording rec = load_recording(db);
  ASSERT_GT(rec.samples.size(), 2500u);

  // The held span: the samples with button 1 down (one run of them).
  std::size_t first = rec.samples.size(), last = 0;
  for (std::size_t i = 0; i < rec.samples.size(); ++i)
    if ((rec.samples[i].buttons & 2u) != 0) {
      first = std::min(first, i);
      last = i;
    }
  ASSERT_LT(first, last) << "the clutch button was never held";
  ASSERT_LT(last + 500, rec.samples.size()) << "no motion recorded after the release";
  EXPECT_GT(last - first, 800u);
  const Vec3 held = rec.samples[first].haptic.p, held_graphic = rec.samples[first].graphic.p;
  for (std::size_t i = first; i <= last; ++i) {
    EXPECT_EQ((rec.samples[i].buttons & 2u), 2u) << "the button was released and pressed again at " << i;
    EXPECT_LT((rec.samples[i].haptic.p - held).norm(), 1e-9)
        << "the haptic tool moved at t = " << rec.samples[i].t;
    EXPECT_LT((rec.samples[i].graphic.p - held_graphic).norm(), 0.05)
        << "the graphic tool moved at t = " << rec.samples[i].t;
  }
  // Before the press, the tool followed the hand.
  double before = 0.0;
  for (std::size_t i = 0; i < first; ++i) before = std::max(before, (rec.samples[i].haptic.p - held).norm());
  EXPECT_GT(before, 10.0) << "mm: the hand did not move the tool before the clutch";
  // After the release: it starts from where it stood and follows the hand again.
  EXPECT_LT((rec.samples[last + 1].haptic.p - held).norm(), 0.1) << "mm: a jump at the release";
  double after = 0.0;
  for (std::size_t i = last + 1; i < rec.samples.size(); ++i)
    after = std::max(after, (rec.samples[i].haptic.p - held).norm());
  EXPECT_GT(after, 10.0) << "mm: the tool did not follow the hand after the release";
  // No step flagged as a jump; after the first 0.1 s (the stylus, at rest at the origin, catching up
  // with the hand on the circle) none larger than the hand's circle allows: 62.8 mm/s, 0.063 mm per
  // 1 ms step.
  double largest_step = 0.0;
  for (std::size_t i = 0; i < rec.samples.size(); ++i) {
    EXPECT_EQ(rec.samples[i].step_flags & kFlagJumpLimited, 0u) << "t = " << rec.samples[i].t;
    EXPECT_EQ(rec.samples[i].safety_flags & kSafetyJump, 0u) << "t = " << rec.samples[i].t;
    if (i > 0 && rec.samples[i].t > 0.1)
      largest_step = std::max(largest_step, (rec.samples[i].haptic.p - rec.samples[i - 1].haptic.p).norm());
  }
  EXPECT_LT(largest_step, 0.1) << "mm";
}

}  // namespace
}  // namespace cariesim
