// Trainee mode's parts without a window (apps/viewer/trainee.hpp): what a trainee's view draws, the
// instructor's lock, and the window script's parser.
#include "viewer/trainee.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/training/course.hpp"
#include "support/files.hpp"

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

// A passphrase checked to its end (submit, then the worker's outcome).
std::optional<bool> check(InstructorLock& lock, const std::string& passphrase) {
  if (lock.submit(passphrase) != InstructorLock::Submitted::Checking) return std::nullopt;
  return lock.wait();
}

TEST(InstructorLock, RefusesAndCountsWrongPassphrasesAndOpensForTheRightOne) {
  const std::string hash =
      cariesim::training::hash_passphrase("class of 2026", cariesim::training::kPassphraseMinIterations);
  InstructorLock lock(hash);
  EXPECT_TRUE(lock.can_unlock());
  EXPECT_FALSE(lock.unlocked());
  EXPECT_EQ(check(lock, "class of 2025"), std::optional<bool>(false));
  EXPECT_EQ(check(lock, ""), std::optional<bool>(false));
  EXPECT_FALSE(lock.unlocked());
  EXPECT_EQ(lock.refused(), 2);
  EXPECT_EQ(check(lock, "class of 2026"), std::optional<bool>(true));
  EXPECT_TRUE(lock.unlocked());
  EXPECT_EQ(lock.refused(), 2);
  lock.lock();
  EXPECT_FALSE(lock.unlocked());
}

TEST(InstructorLock, WithoutAHashNothingUnlocks) {
  InstructorLock lock;
  EXPECT_FALSE(lock.can_unlock());
  EXPECT_EQ(lock.submit("anything at all"), InstructorLock::Submitted::NoHash);
  EXPECT_FALSE(lock.checking());
  EXPECT_FALSE(lock.unlocked());
  EXPECT_EQ(lock.refused(), 1);
}

// The check runs on a worker thread: submit() returns while PBKDF2 at the highest allowed cost
// (about half a second) is still running, and poll() has nothing until it ends; a second passphrase
// meanwhile is not started. Before, the window's thread itself ran the check and froze (2.7 s).
TEST(InstructorLock, ChecksOffTheCallersThread) {
  const std::string hash =
      cariesim::training::hash_passphrase("class of 2026", cariesim::training::kPassphraseMaxIterations);
  InstructorLock lock(hash);
  EXPECT_EQ(lock.submit("class of 2025"), InstructorLock::Submitted::Checking);
  EXPECT_TRUE(lock.checking());
  EXPECT_EQ(lock.poll(), std::nullopt) << "the outcome is not there at once";
  EXPECT_EQ(lock.submit("class of 2026"), InstructorLock::Submitted::Busy);
  EXPECT_EQ(lock.wait(), std::optional<bool>(false));
  EXPECT_FALSE(lock.checking());
  EXPECT_EQ(lock.refused(), 1);
  EXPECT_EQ(check(lock, "class of 2026"), std::optional<bool>(true));
}

// After three wrong passphrases in a row each try waits 1 s, 2 s, 4 s, ... (at most 300 s) from the end
// of the last wrong one; a try within the wait is refused unchecked; the right one starts over. On the
// lock's own clock, so the test never sleeps. Before, 40 guesses took 7 s.
TEST(InstructorLock, BacksOffAfterThreeWrongPassphrases) {
  const std::string hash =
      cariesim::training::hash_passphrase("class of 2026", cariesim::training::kPassphraseMinIterations);
  auto now = InstructorLock::Clock::now();
  InstructorLock lock(hash, [&now] { return now; });
  const auto advance = [&now](int ms) { now += std::chrono::milliseconds(ms); };
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(lock.wait_seconds(), 0.0) << i;
    EXPECT_EQ(check(lock, "guess " + std::to_string(i)), std::optional<bool>(false));
  }
  EXPECT_DOUBLE_EQ(lock.wait_seconds(), 1.0);
  EXPECT_EQ(lock.submit("guess 3"), InstructorLock::Submitted::Wait);
  EXPECT_EQ(lock.deferred(), 1);
  EXPECT_EQ(lock.refused(), 3) << "a deferred try is not checked";
  advance(999);
  EXPECT_EQ(lock.submit("guess 3"), InstructorLock::Submitted::Wait);
  advance(1);
  EXPECT_EQ(check(lock, "guess 3"), std::optional<bool>(false));
  EXPECT_DOUBLE_EQ(lock.wait_seconds(), 2.0);
  advance(2000);
  EXPECT_EQ(check(lock, "guess 4"), std::optional<bool>(false));
  EXPECT_DOUBLE_EQ(lock.wait_seconds(), 4.0);
  EXPECT_EQ(lock.refused(), 5);
  EXPECT_EQ(lock.deferred(), 2);
  // The right passphrase after the wait opens and starts the count over.
  advance(4000);
  EXPECT_EQ(check(lock, "class of 2026"), std::optional<bool>(true));
  lock.lock();
  EXPECT_EQ(check(lock, "guess 5"), std::optional<bool>(false));
  EXPECT_EQ(lock.wait_seconds(), 0.0);
  // The schedule, and its cap.
  EXPECT_EQ(InstructorLock::backoff_seconds(2), 0.0);
  EXPECT_EQ(InstructorLock::backoff_seconds(3), 1.0);
  EXPECT_EQ(InstructorLock::backoff_seconds(6), 8.0);
  EXPECT_EQ(InstructorLock::backoff_seconds(40), InstructorLock::kMaxBackoff);
  EXPECT_EQ(InstructorLock::backoff_seconds(1000000), InstructorLock::kMaxBackoff);
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
  // A key's or lock's line may end in a comment (docs/viewer.md's example); a passphrase may hold '#'.
  const auto commented = parse_script("0.5 key L   # reveal\n1 lock # again\n2 passphrase a # b\n", "s.txt");
  ASSERT_EQ(commented.size(), 3u);
  EXPECT_EQ(commented[0].argument, "L");
  EXPECT_EQ(commented[1].argument, "");
  EXPECT_EQ(commented[2].argument, "a # b");

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

// docs/viewer.md's `--script` example parses as written (it once stopped at its first comment).
TEST(WindowScript, DocumentedExampleParses) {
  const std::string doc =
      cariesim::test::read_text(std::filesystem::path(CARIESIM_SOURCE_DIR) / "docs" / "viewer.md");
  const std::size_t section = doc.find("`--script FILE` plays");
  ASSERT_NE(section, std::string::npos) << "docs/viewer.md describes --script";
  const std::string fence = "```text\n";
  const std::size_t begin = doc.find(fence, section);
  ASSERT_NE(begin, std::string::npos);
  const std::size_t end = doc.find("```", begin + fence.size());
  ASSERT_NE(end, std::string::npos);
  const auto steps = parse_script(doc.substr(begin + fence.size(), end - begin - fence.size()), "viewer.md");
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_EQ(steps[0].action, "key");
  EXPECT_EQ(steps[0].argument, "L");
  EXPECT_EQ(steps[1].action, "passphrase");
  EXPECT_EQ(steps[1].argument, "not it");
  EXPECT_EQ(steps[2].action, "lock");
}

}  // namespace
