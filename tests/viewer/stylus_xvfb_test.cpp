// The study's diagnosis marks from the stylus alone, end to end under Xvfb: `cariesim run --course ...
// --device touch --device-profile FILE` over the stand-in libHD.so (tests/device/standins/hd), whose
// scripted buttons (CARIESIM_STANDIN_HD_BUTTONS) press the buttons the profile maps to mark severe, mark
// mild and end case; the study database holds the marks with the profile's grades, and the case ended
// at the end-case button (the study sets no time limit and no answers file plays the participant).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cariesim/training/course.hpp"
#include "support/command.hpp"
#include "support/files.hpp"
#include "viewer_support.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using test::sql_rows;

TEST(StylusXvfb, MarkAndEndCaseButtonsReachTheStudyDatabase) {
  if (!test::have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  if (!test::on_path("sqlite3")) GTEST_SKIP() << "the sqlite3 shell is not installed";
  const fs::path dir = test::viewer_artefacts() / "stylus-study";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // diagnosis-small's one case without its time limit: only End case ends it.
  const fs::path examples = fs::path(CARIESIM_SOURCE_DIR) / "studies" / "examples";
  std::string study = test::read_text(examples / "diagnosis-small.yaml");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"scene: one-molar.yaml", "scene: '" + (examples / "one-molar.yaml").string() + "'"},
           {"time_limit: 10.0", "time_limit: 0"}}) {
    const std::size_t at = study.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    study.replace(at, from.size(), to);
  }
  std::ofstream(dir / "study.yaml") << study;
  std::ofstream(dir / "course.yaml") << "course: Stylus test\nstudy: study.yaml\nrecords: records\n"
                                        "station: xvfb-1\ninstructor: "
                                     << training::hash_passphrase("stylus test passphrase",
                                                                  training::kPassphraseMinIterations)
                                     << "\n";
  // Not the default map: button 0 marks severe, button 1 mild, button 2 ends the case.
  std::ofstream(dir / "profile.yaml") << "buttons: {0: mark_severe, 1: mark_mild, 2: end_case}\n";

  std::vector<std::string> argv = test::xvfb_cariesim();
  for (const std::string& word :
       {std::string("run"), std::string("--course"), (dir / "course.yaml").string(),
        std::string("--participant"), std::string("P09"), std::string("--trials"), std::string("1"),
        std::string("--device"), std::string("touch"), std::string("--device-profile"),
        (dir / "profile.yaml").string(), std::string("--no-realtime"), std::string("--exit-after"),
        std::string("60")})
    argv.push_back(word);
  io::ProcessOptions options;
  // Seconds after the trial's scheduler started: button 0 held 1.5-2.5, button 1 3.5-4.5, button 2
  // from 5.5 on (each press long enough for the window to see it under load).
  options.environment = {"CARIESIM_CACHE_DIR=" + (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string(),
                         std::string("CARIESIM_HD_LIBRARY=") + CARIESIM_STANDIN_HD,
                         "CARIESIM_STANDIN_HD_BUTTONS=1.5:1,2.5:0,3.5:2,4.5:0,5.5:4"};
  const test::CommandOutput c = test::run_command(argv, options);
  std::ofstream(test::viewer_artefacts() / "stylus-study.log", std::ios::binary) << c.out << c.err;
  ASSERT_EQ(c.status, 0) << c.how << "\n" << c.err << c.out;
  EXPECT_THAT(c.err, HasSubstr("trial 1 of 1 ended"));

  // The trial's row: ended, its two marks graded as the profile maps the buttons, in the order
  // pressed, and the case ended by the end-case button (after its press, well before the window's
  // 60 s limit).
  const fs::path db = dir / "records" / "xvfb-1.db";
  EXPECT_EQ(sql_rows(db, "SELECT kind, ended_at IS NOT NULL FROM trials"),
            (std::vector<std::string>{"diagnosis|1"}));
  EXPECT_EQ(sql_rows(db,
                     "SELECT json_extract(m.value, '$.grade') FROM trials, json_each(trials.answers, "
                     "'$.marks') m ORDER BY json_extract(m.value, '$.t')"),
            (std::vector<std::string>{"severe", "mild"}));
  const std::vector<std::string> times = sql_rows(
      db,
      "SELECT json_extract(m.value, '$.t') FROM trials, json_each(trials.answers, '$.marks') m ORDER BY 1");
  ASSERT_EQ(times.size(), 2u);
  EXPECT_GE(std::stod(times[0]), 1.4);
  EXPECT_GE(std::stod(times[1]), 3.4);
  const std::vector<std::string> ended =
      sql_rows(db, "SELECT json_extract(answers, '$.ended_at') FROM trials");
  ASSERT_EQ(ended.size(), 1u);
  ASSERT_FALSE(ended[0].empty()) << "the case did not end by End case";
  EXPECT_GE(std::stod(ended[0]), 5.4);
  EXPECT_LT(std::stod(ended[0]), 30.0);
}

}  // namespace
}  // namespace cariesim
