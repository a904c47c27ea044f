// The debrief in the real window under Xvfb (apps/viewer/debrief.cpp): after each case of a study
// whose file asks for it, the trainee sees the case's lesions, the marks drawn on the tooth and the
// scores in words while the case's recording replays with the ghost tool, and the next case begins
// after it; `cariesim review DB` opens the same debrief for a past trial rebuilt from the database
// alone, and refuses a tampered database naming the row. Screenshots stay in
// build/test-artifacts/viewer/debrief-*.
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cariesim/training/course.hpp"
#include "cariesim/training/headless.hpp"
#include "cariesim/training/run.hpp"
#include "cariesim/training/study.hpp"
#include "support/command.hpp"
#include "viewer_support.hpp"

namespace {

namespace fs = std::filesystem;
using cariesim::test::have_xvfb;
using cariesim::test::Image;
using cariesim::test::json_query;
using cariesim::test::load_png;
using cariesim::test::run_under_xvfb;
using cariesim::test::RunResult;
using cariesim::test::viewer_artefacts;
using ::testing::HasSubstr;
using ::testing::Not;

fs::path examples() { return fs::path(CARIESIM_SOURCE_DIR) / "studies" / "examples"; }

fs::path scratch(const std::string& name) {
  const fs::path dir = viewer_artefacts() / ("debrief-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// diagnosis-small (one severe fossa lesion on one molar) with `debrief`, two trials of
// `time_limit` s; with `generate`, the second case is drawn (two lesions).
fs::path write_study(const fs::path& dir, const std::string& debrief, bool generate,
                     double time_limit = 10.0) {
  const fs::path file = dir / "debrief-small.yaml";
  std::ofstream(file) << fmt::format(
      "name: debrief-small\nkind: diagnosis\ntrials: 2\nseed: 11\n{}"
      "diagnosis:\n  scene: {}\n  time_limit: {:.1f}\n"
      "  sites:\n"
      "    - {{name: 46-occlusal, object: tooth46, site: occlusal, at: [0.0, 0.0, 7.0], normal: [0, 0, 1], "
      "snap_range: 3.0, shape: disk}}\n"
      "    - {{name: 46-mesial, object: tooth46, site: interproximal, at: [4.9, 0.0, 6.4], normal: [1.0, "
      "0.0, "
      "1.2], tangent: [0, 1, 0], snap_range: 2.5, shape: stripe}}\n"
      "  cases:\n    - lesions:\n        - {{site: 46-occlusal, severity: severe, size: 2.2, depth: "
      "2.0}}\n{}",
      debrief.empty() ? "" : "debrief: " + debrief + "\n", (examples() / "one-molar.yaml").string(),
      time_limit,
      generate ? "  generate: {count: [2, 2], size: [1.6, 2.4], mild_depth: [0.6, 1.0], severe_depth: [1.3, "
                 "1.8]}\n"
               : "");
  return file;
}

// A course file in `dir` on `study`, its records in dir/records under `station`.
fs::path write_course(const fs::path& dir, const fs::path& study, const std::string& name,
                      const std::string& station) {
  const fs::path course = dir / "course.yaml";
  std::ofstream(course) << "course: " << name << "\nstudy: " << study.string()
                        << "\nrecords: records\nstation: " << station << "\ninstructor: "
                        << cariesim::training::hash_passphrase("molar probe 46",
                                                               cariesim::training::kPassphraseMinIterations)
                        << "\n";
  return course;
}

// Pixels of the 3-D view (x < view_w) within `tolerance` of `rgb` in every channel.
int pixels_near(const Image& image, int view_w, const std::array<int, 3>& rgb, int tolerance) {
  int n = 0;
  for (int y = 0; y < image.h; ++y)
    for (int x = 0; x < std::min(view_w, image.w); ++x) {
      const unsigned char* p = image.at(x, y);
      if (std::abs(p[0] - rgb[0]) <= tolerance && std::abs(p[1] - rgb[1]) <= tolerance &&
          std::abs(p[2] - rgb[2]) <= tolerance)
        ++n;
    }
  return n;
}

std::string sql(const fs::path& db, const std::string& query) {
  const cariesim::test::CommandOutput c = cariesim::test::run_command({"sqlite3", db.string(), query});
  EXPECT_EQ(c.status, 0) << c.how << "\n" << c.out << c.err;
  return c.out;
}

class DebriefXvfb : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_xvfb())
      GTEST_SKIP() << "xvfb-run is not installed (Debian package xvfb; scripts/setup installs it)";
  }
};

// A course on the study with `debrief: after-each-case`: each case ends (the answers: a severe mark on
// the fossa lesion at 0.9 s, a mild one 3 mm away, End case at 1 s), its debrief replays it, then the
// next case begins; the window ends on the last case's debrief.
TEST_F(DebriefXvfb, AfterEachCaseTheTraineeSeesTheLesionTheMarksAndTheReplay) {
  const fs::path dir = scratch("after-case");
  const fs::path study = write_study(dir, "after-each-case", false);
  const fs::path course = write_course(dir, study, "Debrief test", "xvfb-1");
  const fs::path png = viewer_artefacts() / "debrief-after-case.png";
  fs::remove(png);
  const RunResult r = run_under_xvfb(
      "run --course '" + course.string() +
          "' --participant P01 --device 'scripted:" + (examples() / "probe-fossa.csv").string() +
          "' --answers '" + (examples() / "diagnosis-answers.yaml").string() +
          "' --view occlusal --no-realtime --exit-after 60" + " --screenshot '" + png.string() + "'",
      "debrief-after-case");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  // Both cases ran: the first one's debrief continued to the second.
  EXPECT_THAT(r.err, HasSubstr("trial 1 of 2 ended"));
  EXPECT_THAT(r.err, HasSubstr("trial 2 of 2 ended"));
  // The terminal still tells nothing of the cases.
  for (const char* word : {"lesion", "severe", "mild", "occlusal", "seed"})
    EXPECT_THAT(r.err, Not(HasSubstr(word)));

  // The last frame is the second case's debrief, its replay played to the end.
  const fs::path json = viewer_artefacts() / "debrief-after-case.json";
  EXPECT_EQ(json_query(json, "d['mode']"), "trainee");
  EXPECT_EQ(json_query(json, "'Debrief' in d['panel_sections']"), "True");
  EXPECT_EQ(json_query(json, "d['debrief']['title']"), "Trial 2 of 2");
  EXPECT_EQ(json_query(json, "d['debrief']['review']"), "False");
  EXPECT_EQ(json_query(json, "d['debrief']['lesions']"), "1");
  EXPECT_EQ(json_query(json, "d['debrief']['found']"), "1");
  EXPECT_EQ(json_query(json, "d['debrief']['marks']"), "2");
  EXPECT_EQ(json_query(json, "d['debrief']['replaying']"), "True");
  EXPECT_EQ(json_query(json, "d['debrief']['lines'][0]"), "You found 1 of 1 lesions: all of them.");
  EXPECT_EQ(json_query(json, "d['debrief']['lines'][1]"),
            "Lesion 1 (46-occlusal, severe): found at 0:01, graded severe: right.");
  EXPECT_EQ(json_query(json, "d['study']['ended']"), "2");

  // The marks are drawn over the view: the found one green, the false one red.
  const Image image = load_png(png);
  ASSERT_NE(image.data, nullptr);
  const int view_w = std::stoi(json_query(json, "d['view']['w']"));
  EXPECT_GT(pixels_near(image, view_w, {60, 220, 90}, 12), 10);
  EXPECT_GT(pixels_near(image, view_w, {240, 70, 60}, 12), 10);
  // The database has both trials with their sources.
  const fs::path db = dir / "records" / "xvfb-1.db";
  EXPECT_EQ(sql(db, "SELECT count(*) FROM trials WHERE ended_at IS NOT NULL"), "2\n");
  EXPECT_EQ(sql(db, "SELECT count(*) FROM trial_sources WHERE scene_hash IS NOT NULL"), "2\n");
}

// A trainee without an answers file: each case ends at its 1 s time limit and its debrief stays until
// it is continued; Enter (a --script key, 1.5 s into the first debrief's replay, after the replay has
// played) continues it with the stylus still in hand, and the second case runs. Without the key the
// first debrief would stay until --exit-after.
TEST_F(DebriefXvfb, EnterContinuesTheDebriefToTheNextCase) {
  const fs::path dir = scratch("enter");
  const fs::path study = write_study(dir, "after-each-case", false, 1.0);
  const fs::path course = write_course(dir, study, "Debrief by key", "xvfb-4");
  const fs::path script = dir / "keys.txt";
  std::ofstream(script) << "1.5 key Enter   # the first debrief's replay (1 s) has played\n";
  const fs::path png = viewer_artefacts() / "debrief-enter.png";
  fs::remove(png);
  const RunResult r =
      run_under_xvfb("run --course '" + course.string() + "' --participant P01 --device 'scripted:" +
                         (examples() / "probe-fossa.csv").string() + "' --script '" + script.string() +
                         "' --no-realtime --exit-after 8 --screenshot '" + png.string() + "'",
                     "debrief-enter");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_THAT(r.err, HasSubstr("trial 1 of 2 ended"));
  EXPECT_THAT(r.err, HasSubstr("trial 2 of 2 ended"));
  const fs::path json = viewer_artefacts() / "debrief-enter.json";
  EXPECT_EQ(json_query(json, "d['debrief']['title']"), "Trial 2 of 2");
  EXPECT_EQ(json_query(json, "d['study']['ended']"), "2");
  // The second case ran its whole time, so the window ended on its debrief, not at --exit-after.
  EXPECT_LT(std::stod(json_query(json, "d['t']")), 8.0);
}

// `debrief: at-end`: both cases run first, then each case's debrief (its scene built again), the
// window ending on the last one.
TEST_F(DebriefXvfb, AtTheEndEachCaseIsDebriefedAfterTheLast) {
  const fs::path dir = scratch("at-end");
  const fs::path study = write_study(dir, "at-end", false);
  const fs::path course = write_course(dir, study, "Debrief at the end", "xvfb-3");
  const fs::path png = viewer_artefacts() / "debrief-at-end.png";
  const RunResult r = run_under_xvfb(
      "run --course '" + course.string() +
          "' --participant P01 --device 'scripted:" + (examples() / "probe-fossa.csv").string() +
          "' --answers '" + (examples() / "diagnosis-answers.yaml").string() +
          "' --no-realtime --exit-after 60 --screenshot '" + png.string() + "'",
      "debrief-at-end");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  // Both trials ended before the first debrief was built.
  const std::size_t second = r.err.find("trial 2 of 2 ended");
  const std::size_t first_debrief = r.err.find("building debrief of Trial 1 of 2");
  ASSERT_NE(second, std::string::npos) << r.err;
  ASSERT_NE(first_debrief, std::string::npos) << r.err;
  EXPECT_LT(second, first_debrief);
  EXPECT_THAT(r.err, HasSubstr("building debrief of Trial 2 of 2"));
  const fs::path json = viewer_artefacts() / "debrief-at-end.json";
  EXPECT_EQ(json_query(json, "d['debrief']['title']"), "Trial 2 of 2");
  EXPECT_EQ(json_query(json, "d['debrief']['found']"), "1");
}

// Without `debrief` (an exam) no debrief is shown: the study ends as before.
TEST_F(DebriefXvfb, WithoutDebriefTheStudyEndsWithoutOne) {
  const fs::path dir = scratch("never");
  const fs::path study = write_study(dir, "", false);
  const fs::path course = write_course(dir, study, "Exam", "xvfb-2");
  const fs::path png = viewer_artefacts() / "debrief-never.png";
  const RunResult r = run_under_xvfb(
      "run --course '" + course.string() +
          "' --participant P01 --device 'scripted:" + (examples() / "probe-fossa.csv").string() +
          "' --answers '" + (examples() / "diagnosis-answers.yaml").string() +
          "' --no-realtime --exit-after 60 --screenshot '" + png.string() + "'",
      "debrief-never");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const fs::path json = viewer_artefacts() / "debrief-never.json";
  EXPECT_EQ(json_query(json, "d['debrief']"), "None");
  EXPECT_EQ(json_query(json, "'Debrief' in d['panel_sections']"), "False");
  EXPECT_EQ(json_query(json, "d['study']['ended']"), "2");
}

// `cariesim review DB --participant P01 --trial 2`: the drawn second case rebuilt from the database
// alone (the study file deleted), its scene checked against the recording, its debrief and replay.
// A tampered database is refused naming the row.
TEST_F(DebriefXvfb, ReviewRebuildsAPastDrawnCaseFromTheDatabaseAlone) {
  const fs::path dir = scratch("review");
  const fs::path study = write_study(dir, "", true);
  const fs::path db = dir / "class.db";
  {
    cariesim::training::RunOptions o;
    o.participant = "P01";
    o.database = db;
    cariesim::training::StudyRun run(cariesim::training::load_study(study.string()), o);
    cariesim::training::HeadlessOptions headless;
    headless.device = "scripted:" + (examples() / "probe-fossa.csv").string();
    ASSERT_EQ(cariesim::training::run_headless(
                  run, cariesim::training::load_answers(examples() / "diagnosis-answers.yaml"), headless)
                  .size(),
              2u);
  }
  fs::remove(study);
  const fs::path png = viewer_artefacts() / "debrief-review.png";
  fs::remove(png);
  const RunResult r = run_under_xvfb("review '" + db.string() +
                                         "' --participant P01 --trial 2 --view occlusal --no-realtime" +
                                         " --exit-after 0.95 --screenshot '" + png.string() + "'",
                                     "debrief-review");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const fs::path json = viewer_artefacts() / "debrief-review.json";
  EXPECT_EQ(json_query(json, "d['mode']"), "full");
  EXPECT_EQ(json_query(json, "d['debrief']['title']"), "P01, trial 2 (row 2)");
  EXPECT_EQ(json_query(json, "d['debrief']['review']"), "True");
  EXPECT_EQ(json_query(json, "d['debrief']['lesions']"), "2");
  EXPECT_EQ(json_query(json, "d['debrief']['marks']"), "2");
  EXPECT_EQ(json_query(json, "d['debrief']['replaying']"), "True");
  EXPECT_EQ(json_query(json, "d['lesions_shown']"), "True");

  // The study's text changed in the database: refused naming the table, row and column.
  sql(db, "UPDATE studies SET yaml = replace(yaml, 'time_limit: 10.0', 'time_limit: 11.0')");
  const RunResult text = run_under_xvfb(
      "review '" + db.string() + "' --participant P01 --trial 2 --no-realtime", "debrief-review-text");
  EXPECT_NE(text.status, 0);
  EXPECT_THAT(text.err, HasSubstr("studies, row 1, column yaml"));
  sql(db, "UPDATE studies SET yaml = replace(yaml, 'time_limit: 11.0', 'time_limit: 10.0')");
  // The recorded scene hash changed: the rebuilt scene does not match it.
  sql(db, "UPDATE trial_sources SET scene_hash = '0123456789abcdef' WHERE trial_id = 2");
  const RunResult hash = run_under_xvfb(
      "review '" + db.string() + "' --participant P01 --trial 2 --no-realtime", "debrief-review-hash");
  EXPECT_NE(hash.status, 0);
  EXPECT_THAT(hash.err, HasSubstr("trial_sources, row 2, column scene_hash"));
  EXPECT_THAT(hash.err, HasSubstr("0123456789abcdef"));
}

}  // namespace
