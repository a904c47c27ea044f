// Trainee mode's parts without a window (apps/viewer/trainee.hpp): what a trainee's view draws, the
// instructor's lock, and the window script's parser.
#include "viewer/trainee.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cariesim/common/error.hpp"
#include "cariesim/training/course.hpp"

namespace {

using cariesim::Error;
using cariesim::viewer::InstructorLock;
using cariesim::viewer::parse_script;
using cariesim::viewer::trainee_settings;
using cariesim::viewer::ViewSettings;
using ::testing::HasSubstr;

TEST(TraineeSettings, DrawTissuesAndTheToolOnly) {
  // Everything on, as an instructor might leave it.
  ViewSettings all;
  all.show_lesions = all.haptic_ghost = all.recorded_ghost = all.contacts = all.tunnel = true;
  all.force_arrow = all.tip_xray = all.trees = all.dents = true;
  const ViewSettings t = trainee_settings(all);
  EXPECT_FALSE(t.show_lesions);
  EXPECT_FALSE(t.haptic_ghost);
  EXPECT_FALSE(t.recorded_ghost);
  EXPECT_FALSE(t.contacts);
  EXPECT_FALSE(t.tunnel);
  EXPECT_FALSE(t.force_arrow);
  EXPECT_FALSE(t.tip_xray);
  EXPECT_FALSE(t.trees);
  EXPECT_TRUE(t.dents) << "soft-tissue dents show where the trainee presses, not lesions";
}

TEST(InstructorLock, RefusesAndCountsWrongPassphrasesAndOpensForTheRightOne) {
  const std::string hash =
      cariesim::training::hash_passphrase("class of 2026", cariesim::training::kPassphraseMinIterations);
  InstructorLock lock(hash);
  EXPECT_TRUE(lock.can_unlock());
  EXPECT_FALSE(lock.unlocked());
  EXPECT_FALSE(lock.try_unlock("class of 2025"));
  EXPECT_FALSE(lock.try_unlock(""));
  EXPECT_FALSE(lock.unlocked());
  EXPECT_EQ(lock.refused(), 2);
  EXPECT_TRUE(lock.try_unlock("class of 2026"));
  EXPECT_TRUE(lock.unlocked());
  EXPECT_EQ(lock.refused(), 2);
  lock.lock();
  EXPECT_FALSE(lock.unlocked());
}

TEST(InstructorLock, WithoutAHashNothingUnlocks) {
  InstructorLock lock;
  EXPECT_FALSE(lock.can_unlock());
  EXPECT_FALSE(lock.try_unlock("anything at all"));
  EXPECT_FALSE(lock.unlocked());
  EXPECT_EQ(lock.refused(), 1);
}

TEST(WindowScript, ParsesStepsAndNamesBadLines) {
  const auto steps =
      parse_script("# comment\n\n0.5 key L\n1 passphrase two words here\n1.5 lock\n2 key Enter\n", "s.txt");
  ASSERT_EQ(steps.size(), 4u);
  EXPECT_EQ(steps[0].action, "key");
  EXPECT_EQ(steps[0].argument, "L");
  EXPECT_DOUBLE_EQ(steps[0].t, 0.5);
  EXPECT_EQ(steps[0].line, 3);
  EXPECT_EQ(steps[1].argument, "two words here");
  EXPECT_EQ(steps[2].action, "lock");
  EXPECT_EQ(cariesim::viewer::script_key_code("Enter"), cariesim::viewer::script_key_code(steps[3].argument));

  const auto error = [](const std::string& text) -> std::string {
    try {
      (void)parse_script(text, "s.txt");
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_THAT(error("1 key L\n0.5 key R\n"), HasSubstr("s.txt:2: time 0.5 s is before"));
  EXPECT_THAT(error("x key L\n"), HasSubstr("s.txt:1: 'x' is not a time"));
  EXPECT_THAT(error("-1 key L\n"), HasSubstr("s.txt:1:"));
  EXPECT_THAT(error("1 key F12\n"), HasSubstr("unknown key 'F12'"));
  EXPECT_THAT(error("1 jump\n"), HasSubstr("unknown action 'jump'"));
  EXPECT_THAT(error("1 lock now\n"), HasSubstr("lock takes no argument"));
  EXPECT_THAT(cariesim::viewer::script_key_code("q"), cariesim::viewer::script_key_code("Q"));
  EXPECT_EQ(cariesim::viewer::script_key_code("ab"), -1);
}

}  // namespace
