// `cariesim course hash` and `cariesim course check` as a user runs them: the hash printed verifies
// against the passphrase given on stdin, a short passphrase and a bad course file are refused with
// the reason (exit status 2).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cariesim/training/course.hpp"
#include "support/command.hpp"
#include "support/files.hpp"
#include "viewer_support.hpp"

namespace {

namespace fs = std::filesystem;
using cariesim::test::read_text;
using ::testing::HasSubstr;

struct Cli {
  int status = -1;
  std::string out, err;
};

// `cariesim ARGS` with `input` on stdin.
Cli cariesim(const std::string& args, const std::string& input) {
  const fs::path dir = cariesim::test::viewer_artefacts() / "course-cli";
  fs::create_directories(dir);
  std::ofstream(dir / "stdin.txt") << input;
  cariesim::io::ProcessOptions options;
  options.stdin_file = (dir / "stdin.txt").string();
  const cariesim::test::CommandOutput c = cariesim::test::run_command(CARIESIM_EXE, args, options);
  Cli r;
  r.status = c.status;
  r.out = c.out;
  r.err = c.err;
  return r;
}

TEST(CourseCli, HashPrintsAVerifiableHash) {
  const Cli r = cariesim("course hash --iterations 100000", "lab passphrase 9\n");
  ASSERT_EQ(r.status, 0) << r.err;
  std::string hash = r.out;
  while (!hash.empty() && hash.back() == '\n') hash.pop_back();
  EXPECT_THAT(hash, ::testing::StartsWith("pbkdf2-sha256$100000$"));
  EXPECT_TRUE(cariesim::training::verify_passphrase("lab passphrase 9", hash));
  EXPECT_FALSE(cariesim::training::verify_passphrase("lab passphrase 9\n", hash))
      << "the line end is not part of it";

  const Cli short_one = cariesim("course hash", "short\n");
  EXPECT_EQ(short_one.status, 2);
  EXPECT_THAT(short_one.err, HasSubstr("at least 8 are needed"));
  const Cli none = cariesim("course hash", "");
  EXPECT_EQ(none.status, 2);
  EXPECT_THAT(none.err, HasSubstr("no passphrase on standard input"));
}

TEST(CourseCli, CheckNamesTheProblemsPlace) {
  const fs::path dir = cariesim::test::viewer_artefacts() / "course-cli";
  fs::create_directories(dir);
  const std::string hash =
      cariesim::training::hash_passphrase("lab passphrase 9", cariesim::training::kPassphraseMinIterations);
  std::ofstream(dir / "good.yaml")
      << "course: C\nstudy: boundary-shapes\nrecords: r\nstation: s1\ninstructor: " << hash << "\n";
  std::ofstream(dir / "bad.yaml")
      << "course: C\nstudy: boundary-shapes\nrecords: r\nstation: s 1\ninstructor: " << hash << "\n";
  const Cli good = cariesim("course check '" + (dir / "good.yaml").string() + "'", "");
  ASSERT_EQ(good.status, 0) << good.err;
  EXPECT_THAT(good.out, HasSubstr("boundary-shapes (built-in): boundary-shapes, 10 trials"));
  EXPECT_THAT(good.out, HasSubstr("s1.db"));
  const Cli bad = cariesim("course check '" + (dir / "bad.yaml").string() + "'", "");
  EXPECT_EQ(bad.status, 2);
  EXPECT_THAT(bad.err, HasSubstr("bad.yaml:4:10: station: 's 1' is not a valid name"));
}

}  // namespace
