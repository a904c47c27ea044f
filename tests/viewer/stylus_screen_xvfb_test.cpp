// The trainee's screen with a stylus in hand, under Xvfb (docs/viewer.md "Trainee mode"): keys 1 and
// 2 choose the grade of the next mark and M marks, the chosen grade shown large; the occlusal view
// sees the probed tooth past the explorer's handle; the panel fits the window at 1280x800 and
// 1920x1080 (nothing reaches past its right edge); an answers file's marks land at their servo times
// and tips; the next trial's scene builds while the trainee works on the current one. Screenshots
// stay in build/test-artifacts/viewer/screen-*.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
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

namespace {

namespace fs = std::filesystem;
using cariesim::test::have_xvfb;
using cariesim::test::json_query;
using cariesim::test::read_text;
using cariesim::test::run_under_xvfb;
using cariesim::test::RunResult;
using cariesim::test::viewer_artefacts;
using ::testing::HasSubstr;

using cariesim::test::sql_rows;

// A scratch folder for course files and databases.
fs::path scratch(const std::string& name) {
  const fs::path dir = viewer_artefacts() / ("screen-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A course in `dir` on diagnosis-small (the one-molar case, a quick build) with `trials` trials and
// no time limit.
fs::path small_course(const fs::path& dir, int trials) {
  const fs::path examples = fs::path(CARIESIM_SOURCE_DIR) / "studies" / "examples";
  std::string study = read_text(examples / "diagnosis-small.yaml");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"scene: one-molar.yaml", "scene: '" + (examples / "one-molar.yaml").string() + "'"},
           {"time_limit: 10.0", "time_limit: 0"},
           {"trials: 1", "trials: " + std::to_string(trials)}}) {
    const std::size_t at = study.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) study.replace(at, from.size(), to);
  }
  std::ofstream(dir / "study.yaml") << study;
  const fs::path course = dir / "course.yaml";
  std::ofstream(course)
      << "course: Stylus screen test\nstudy: study.yaml\nrecords: records\nstation: xvfb-s\n"
      << "instructor: "
      << cariesim::training::hash_passphrase("stylus screen 1", cariesim::training::kPassphraseMinIterations)
      << "\n";
  return course;
}

// `cariesim run ARGS --no-realtime --exit-after S --screenshot screen-NAME.png` on a `screen` display.
RunResult shot(const std::string& name, const std::string& args, double exit_after,
               const std::string& screen = "1280x800") {
  const fs::path png = viewer_artefacts() / ("screen-" + name + ".png");
  fs::remove(png);
  return run_under_xvfb("run " + args + " --no-realtime --exit-after " + std::to_string(exit_after) +
                            " --screenshot '" + png.string() + "'",
                        "screen-" + name, {}, screen);
}

fs::path json_of(const std::string& name) { return viewer_artefacts() / ("screen-" + name + ".json"); }

double json_number(const fs::path& json, const std::string& expression) {
  const std::string text = json_query(json, expression);
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  EXPECT_NE(end, text.c_str()) << expression << ": " << text;
  return value;
}

class StylusScreenXvfb : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_xvfb())
      GTEST_SKIP() << "xvfb-run is not installed (Debian package xvfb; scripts/setup installs it)";
    if (!cariesim::test::on_path("sqlite3")) GTEST_SKIP() << "the sqlite3 shell is not installed";
  }
};

// Keys 1 and 2 choose the grade in a diagnosis case and M marks with it: trial 1's marks are severe
// (after 2) and mild (after 1). The chosen grade is drawn large in the panel (its box in the status
// file: half the panel wide, twice a text line high); the status file names it. Before, 1 and 2 turned
// the camera, both marks were mild (the radio button's default) and the grade was a radio button.
TEST_F(StylusScreenXvfb, KeysOneAndTwoChooseTheGradeShownLarge) {
  const fs::path dir = scratch("keys");
  const fs::path course = small_course(dir, 2);
  std::ofstream(dir / "answers.yaml") << "trials:\n  - end: 1.0\n  - end: 30.0\n";
  std::ofstream(dir / "keys.txt") << "0.2 key 2\n0.4 key M\n0.6 key 1\n0.8 key M\n1.0 key 2\n";
  const RunResult r =
      shot("keys",
           "--course '" + course.string() + "' --participant P01 --device null --answers '" +
               (dir / "answers.yaml").string() + "' --script '" + (dir / "keys.txt").string() + "'",
           3.0);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const fs::path db = dir / "records" / "xvfb-s.db";
  EXPECT_EQ(
      sql_rows(db,
               "SELECT json_extract(m.value, '$.grade') FROM trials t, json_each(json_extract(t.answers, "
               "'$.marks')) m WHERE t.trial = 1 ORDER BY json_extract(m.value, '$.t')"),
      (std::vector<std::string>{"severe", "mild"}));
  // Trial 2 runs at the screenshot: the grade chosen last (2) shown large.
  const fs::path json = json_of("keys");
  EXPECT_EQ(json_query(json, "d['study']['in_trial']"), "True");
  EXPECT_EQ(json_query(json, "d['study']['grade']"), "severe");
  EXPECT_GE(json_number(json, "d['study']['grade_box']['w']"), 0.4 * json_number(json, "d['panel']['w']"));
  EXPECT_GE(json_number(json, "d['study']['grade_box']['h']"), 30.0);
}

// The panel fits the window at 1280x800 and 1920x1080, in a trainee's diagnosis case and in the full
// panel: nothing reaches past its right edge (the status file's panel.overflow_x, ImGui's horizontal
// scroll extent of the panel's content). Before, the View section's preset buttons ("4 op") and the
// mouse hints ("right-drag tu") ran past it.
TEST_F(StylusScreenXvfb, NothingIsClippedAtEitherScreenSize) {
  const fs::path dir = scratch("fit");
  const fs::path course = small_course(dir, 1);
  std::ofstream(dir / "answers.yaml") << "trials:\n  - end: 30.0\n";
  const fs::path scene = fs::path(CARIESIM_SOURCE_DIR) / "studies" / "examples" / "one-molar.yaml";
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1280, 800}, {1920, 1080}}) {
    const std::string size = std::to_string(w) + "x" + std::to_string(h);
    const std::string sizes = " --size " + std::to_string(w) + " " + std::to_string(h);
    const RunResult trainee =
        shot("fit-trainee-" + size,
             "--course '" + course.string() + "' --participant P0" + std::to_string(w % 7) +
                 " --device null --answers '" + (dir / "answers.yaml").string() + "'" + sizes,
             1.0, size);
    ASSERT_EQ(trainee.status, 0) << trainee.err;
    const RunResult full =
        shot("fit-full-" + size, "'" + scene.string() + "' --device null" + sizes, 1.0, size);
    ASSERT_EQ(full.status, 0) << full.err;
    for (const std::string& name : std::vector<std::string>{"fit-trainee-" + size, "fit-full-" + size}) {
      EXPECT_EQ(json_number(json_of(name), "d['width']"), w) << name;
      EXPECT_EQ(json_number(json_of(name), "d['height']"), h) << name;
      EXPECT_EQ(json_query(json_of(name), "d['panel']['overflow_x']"), "0") << name;
    }
    EXPECT_THAT(json_query(json_of("fit-trainee-" + size), "d['panel_sections']"), HasSubstr("View"));
  }
}

// An answers file's marks happen at their servo times, as in `cariesim study run`: the database's
// mark times are the file's (within a servo period) and each mark's tip is the recorded graphic tool
// at that time, while the scripted tool moves 20 mm/s. Before, the window marked when it next drew
// after the time (about 0.17 s late under Xvfb) at the tip of that frame.
TEST_F(StylusScreenXvfb, ScriptedMarksLandAtTheirServoTimes) {
  const fs::path dir = scratch("timing");
  const fs::path course = small_course(dir, 1);
  // The one-molar tool's home orientation, moving 40 mm along x above the tooth in 2 s.
  std::ofstream(dir / "path.csv") << "t,px,py,pz,qw,qx,qy,qz\n"
                                  << "0,-20,0,20,0.965926,0,-0.258819,0\n"
                                  << "2,20,0,20,0.965926,0,-0.258819,0\n"
                                  << "3,20,0,20,0.965926,0,-0.258819,0\n";
  const std::vector<double> times{0.25, 0.5, 0.75, 1.25};
  std::ofstream answers(dir / "answers.yaml");
  answers << "trials:\n  - end: 1.6\n    marks:\n";
  for (std::size_t i = 0; i < times.size(); ++i)
    answers << "      - {t: " << times[i] << ", grade: " << (i % 2 == 0 ? "mild" : "severe") << "}\n";
  answers.close();
  const RunResult r = shot("timing",
                           "--course '" + course.string() +
                               "' --participant P02 --device 'scripted:" + (dir / "path.csv").string() +
                               "' --answers '" + (dir / "answers.yaml").string() + "'",
                           30.0);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const fs::path db = dir / "records" / "xvfb-s.db";
  const std::vector<std::string> marks =
      sql_rows(db,
               "SELECT json_extract(m.value, '$.t'), json_extract(m.value, '$.tip[0]') FROM trials t, "
               "json_each(json_extract(t.answers, '$.marks')) m ORDER BY json_extract(m.value, '$.t')");
  ASSERT_EQ(marks.size(), times.size());
  const std::vector<std::string> recording = sql_rows(db, "SELECT recording FROM trials");
  ASSERT_EQ(recording.size(), 1u);
  for (std::size_t i = 0; i < times.size(); ++i) {
    const double t = std::stod(marks[i].substr(0, marks[i].find('|')));
    const double x = std::stod(marks[i].substr(marks[i].find('|') + 1));
    EXPECT_NEAR(t, times[i], 0.002) << "mark " << i;
    // The recorded graphic tool's x at the sample nearest the mark's time.
    const std::vector<std::string> sample =
        sql_rows(dir / "records" / recording[0],
                 "SELECT g_px FROM samples ORDER BY abs(t - " + std::to_string(times[i]) + ") LIMIT 1");
    ASSERT_EQ(sample.size(), 1u);
    EXPECT_NEAR(x, std::stod(sample[0]), 0.05) << "mark " << i << ": the tip then (20 mm/s)";
  }
}

// The occlusal view on real-arch with the explorer touching 37 (the viewer's scripted touch): the line
// of sight from the camera to the tip stays clear of the handle. The status file's tool points (every
// 10 mm along the tool, in the image) keep away from the tip's pixel beyond the working end, and its
// tool_clearance_deg is at least the preset's 12°. Before, the camera looked straight down the handle,
// which passed over the tip (the points 10 and 20 mm up the tool on either side of it in the image).
TEST_F(StylusScreenXvfb, OcclusalViewLooksPastTheHandle) {
  const fs::path path =
      fs::path(CARIESIM_SOURCE_DIR) / "scenes" / "trajectories" / "viewer-touch-real-arch.csv";
  const RunResult r =
      shot("occlusal", "real-arch --trainee --view occlusal --device 'scripted:" + path.string() + "'", 3.0);
  ASSERT_EQ(r.status, 0) << r.err;
  const fs::path json = json_of("occlusal");
  EXPECT_GE(json_number(json, "d['tool_clearance_deg']"), 12.0 - 1e-6);
  // The image distance from the tip to the tool's centre line beyond its first 10 mm (segments
  // between the points), in px.
  const double distance = json_number(
      json,
      "(lambda t, p: min(((lambda ax, ay, bx, by: (lambda u: ((ax + u * (bx - ax) - t[0]) ** 2 + (ay + u * "
      "(by - ay) - t[1]) ** 2) ** 0.5)(max(0.0, min(1.0, ((t[0] - ax) * (bx - ax) + (t[1] - ay) * (by - ay)) "
      "/ max(1e-9, (bx - ax) ** 2 + (by - ay) ** 2)))))(*p[i], *p[i + 1]) for i in range(1, len(p) - 1)), "
      "default=1e9))(d['tip'], d['tool_points'])");
  EXPECT_GT(distance, 40.0);
}

// The next trial's scene builds in the background while the trainee works on the current one: the
// window starts building trial 2 once trial 1 runs, and trial 2 starts on that build. Before, trial
// 2's build began only after trial 1 ended, the trainee waiting for it.
TEST_F(StylusScreenXvfb, TheNextTrialBuildsWhileTheTraineeWorks) {
  const fs::path dir = scratch("ahead");
  const fs::path course = small_course(dir, 2);
  std::ofstream(dir / "answers.yaml") << "trials:\n  - end: 2.0\n  - end: 0.5\n";
  const RunResult r = shot("ahead",
                           "--course '" + course.string() + "' --participant P03 --device null --answers '" +
                               (dir / "answers.yaml").string() + "'",
                           30.0);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const std::size_t ahead = r.err.find("run: building trial 2 of 2 in the background");
  const std::size_t ended = r.err.find("run: trial 1 of 2 ended");
  ASSERT_NE(ahead, std::string::npos) << r.err;
  ASSERT_NE(ended, std::string::npos) << r.err;
  EXPECT_LT(ahead, ended) << r.err;
  EXPECT_THAT(r.err, HasSubstr("run: trial 2 of 2 was built in the background"));
  EXPECT_THAT(r.err, HasSubstr("run: trial 2 of 2 ended"));
  EXPECT_EQ(sql_rows(dir / "records" / "xvfb-s.db", "SELECT count(*) FROM trials WHERE ended_at IS NOT NULL"),
            (std::vector<std::string>{"2"}));
}

}  // namespace
