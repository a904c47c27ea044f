// `cariesim servo --device touch` end to end over the stand-in libHD.so (tests/device/standins/hd),
// its hand tracing a circle (CARIESIM_STANDIN_HD=circle): the servo loop runs clocked by HD's
// scheduler, the Touch's force limit in force, and reports the device's counters; with no OpenHaptics library
// the command fails naming what it tried and what to install; a profile's clutch button held while the
// hand moves keeps the recorded tool still, and its release re-indexes without a jump; in `cariesim
// study run --device touch` the profile's buttons mark and end a diagnosis case. The Touch unplugged
// mid-run (CARIESIM_STANDIN_HD=circle,unplug-at-1s) ends the run cleanly, its record closed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "apps/apps_support.hpp"
#include "cariesim/device/safety.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/render/interaction.hpp"
#include "servo/servo_support.hpp"
#include "support/command.hpp"

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

using test::sql_rows;

// The headless study with the Touch: the answers file has no marks and no end; the stand-in presses
// button 0 (the profile's mark severe) at 0.5 s, button 1 (mark mild) at 1.2 s and button 2 (end case)
// at 2 s. The trial's row has the two marks with those grades and the case ended at the end-case
// press, its recording stopping there rather than at --duration. Before, the profile's buttons did
// nothing headless: no marks, and the case ran to --duration without an end.
TEST_F(TouchRun, StudyRunMarksAndEndsTheCaseFromTheProfilesButtons) {
  if (!test::on_path("sqlite3")) GTEST_SKIP() << "the sqlite3 shell is not installed";
  const std::filesystem::path profile = dir_ / "profile.yaml", answers = dir_ / "answers.yaml",
                              db = dir_ / "study.db";
  std::ofstream(profile) << "buttons: {0: mark_severe, 1: mark_mild, 2: end_case}\n";
  std::ofstream(answers) << "trials:\n  - marks: []\n";
  const test::CommandResult r = test::run_cariesim(
      "study run '" +
          (std::filesystem::path(CARIESIM_SOURCE_DIR) / "studies/examples/diagnosis-small.yaml").string() +
          "' --participant P08 --answers '" + answers.string() + "' --out '" + db.string() +
          "' --device touch --device-profile '" + profile.string() + "' --duration 8 --quiet",
      std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD +
          " CARIESIM_STANDIN_HD_BUTTONS=0.5:1,0.8:0,1.2:2,1.5:0,2.0:4");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(sql_rows(db,
                     "SELECT json_extract(m.value, '$.grade') FROM trials, json_each(trials.answers, "
                     "'$.marks') m ORDER BY json_extract(m.value, '$.t')"),
            (std::vector<std::string>{"severe", "mild"}));
  const std::vector<std::string> ended =
      sql_rows(db, "SELECT json_extract(answers, '$.ended_at') FROM trials");
  ASSERT_EQ(ended.size(), 1u);
  ASSERT_FALSE(ended[0].empty()) << "the case did not end";
  EXPECT_NEAR(std::stod(ended[0]), 2.0, 0.1);
  const std::vector<std::string> recording = sql_rows(db, "SELECT recording FROM trials");
  ASSERT_EQ(recording.size(), 1u);
  const Recording rec = load_recording(db.parent_path() / recording[0]);
  ASSERT_FALSE(rec.samples.empty());
  EXPECT_LT(rec.samples.back().t, 4.0) << "s: the trial ran on after end case";
}

}  // namespace
}  // namespace cariesim
