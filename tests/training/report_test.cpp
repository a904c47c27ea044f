// `cariesim report`'s library: two stations' study databases with known rows give known tables in
// CSV, JSON and HTML; duplicates are counted once; bad inputs are refused naming the file.
#include "cariesim/training/report.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "support/command.hpp"
#include "support/csv.hpp"
#include "support/files.hpp"
#include "training/study_db_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using test::StudyDbWriter;
using ::testing::HasSubstr;
using ::testing::Not;

// A CSV file as rows of column -> text (no quoted commas in these tables' numbers).
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& file) {
  std::istringstream in(read_text(file));
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& l) {
    std::vector<std::string> f;
    std::string cell;
    std::istringstream s(l);
    while (std::getline(s, cell, ',')) f.push_back(cell);
    if (!l.empty() && l.back() == ',') f.emplace_back();
    return f;
  };
  if (!std::getline(in, line)) return rows;
  header = split(line);
  while (std::getline(in, line)) {
    const std::vector<std::string> f = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size(); ++i) row[header[i]] = i < f.size() ? f[i] : "";
    rows.push_back(std::move(row));
  }
  return rows;
}

const std::map<std::string, std::string>& row_of(const std::vector<std::map<std::string, std::string>>& rows,
                                                 const std::string& key, const std::string& value) {
  for (const auto& r : rows)
    if (r.at(key) == value) return r;
  throw std::runtime_error("no row with " + key + " = " + value);
}

// Whether `text` holds `what`; a failure names `what` only (the texts are long).
::testing::AssertionResult has(const std::string& text, const std::string& what) {
  if (text.find(what) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "missing: " << what;
}

double num(const std::map<std::string, std::string>& row, const std::string& key) {
  const std::string& text = row.at(key);
  EXPECT_FALSE(text.empty()) << key;
  return text.empty() ? -1.0 : std::stod(text);
}

TrialScore score(const char* name, const char* level, double value, const char* unit = "") {
  return TrialScore{name, level, value, unit};
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("cariesim_report_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Two stations. Station A: P1's two tuning trials and three boundary trials (inserted out of time
  // order). Station B: P2's two tuning trials, an unfinished third one (left out), two boundary
  // trials and two diagnosis cases.
  void make_two_stations() {
    StudyDbWriter a(dir_ / "station-a.db", "station-a");
    a.trial("P1", "tuning", "tuning", 1, "2026-11-20T09:00:00.000Z", "2026-11-20T09:05:00.000Z",
            {score("mu_s", "mild", 0.1), score("mu_s", "severe", 0.5), score("mu_d", "mild", 0.1),
             score("mu_d", "severe", 0.4)});
    a.trial("P1", "tuning", "tuning", 2, "2026-11-20T09:05:00.000Z", "2026-11-20T09:10:00.000Z",
            {score("mu_s", "mild", 0.2), score("mu_s", "severe", 0.7), score("mu_d", "mild", 0.2),
             score("mu_d", "severe", 0.4)});
    // Boundary: trial 3 first in the file, last in time.
    a.trial("P1", "boundary-shapes", "boundary-shapes", 3, "2026-11-20T10:20:00.000Z",
            "2026-11-20T10:25:00.000Z",
            {score("boundary_point", "", 1), score("shape_correct", "square", 1),
             score("shape_correct", "triangle", 1), score("shape_correct", "circle", 1)});
    a.trial("P1", "boundary-shapes", "boundary-shapes", 1, "2026-11-20T10:00:00.000Z",
            "2026-11-20T10:05:00.000Z",
            {score("boundary_point", "", 1), score("shape_correct", "square", 1),
             score("shape_correct", "triangle", 1), score("shape_correct", "circle", 1)});
    a.trial("P1", "boundary-shapes", "boundary-shapes", 2, "2026-11-20T10:10:00.000Z",
            "2026-11-20T10:15:00.000Z",
            {score("boundary_point", "", 0), score("shape_correct", "square", 1),
             score("shape_correct", "triangle", 0), score("shape_correct", "circle", 1)});

    StudyDbWriter b(dir_ / "station-b.db", "station-b");
    b.trial("P2", "tuning", "tuning", 1, "2026-11-21T09:00:00.000Z", "2026-11-21T09:05:00.000Z",
            {score("mu_s", "mild", 0.3), score("mu_s", "severe", 0.8), score("mu_d", "mild", 0.2),
             score("mu_d", "severe", 0.5)});
    b.trial("P2", "tuning", "tuning", 2, "2026-11-21T09:05:00.000Z", "2026-11-21T09:10:00.000Z",
            {score("mu_s", "mild", 0.3), score("mu_s", "severe", 0.9), score("mu_d", "mild", 0.2),
             score("mu_d", "severe", 0.7)});
    b.trial("P2", "tuning", "tuning", 3, "2026-11-21T09:10:00.000Z", std::nullopt,
            {score("mu_s", "mild", 0.99), score("mu_s", "severe", 0.01)});
    b.trial("P2", "boundary-shapes", "boundary-shapes", 1, "2026-11-21T10:00:00.000Z",
            "2026-11-21T10:05:00.000Z",
            {score("boundary_point", "", 0), score("shape_correct", "square", 0),
             score("shape_correct", "triangle", 1), score("shape_correct", "circle", 0)});
    b.trial("P2", "boundary-shapes", "boundary-shapes", 2, "2026-11-21T10:10:00.000Z",
            "2026-11-21T10:15:00.000Z",
            {score("boundary_point", "", 1), score("shape_correct", "square", 1),
             score("shape_correct", "triangle", 1), score("shape_correct", "circle", 1)});
    b.trial(
        "P2", "diagnosis", "diagnosis", 1, "2026-11-21T11:00:00.000Z", "2026-11-21T11:01:00.000Z",
        {score("lesions", "", 3, "count"), score("detected", "", 2, "count"), score("missed", "", 1, "count"),
         score("false_marks", "", 1, "count"), score("detection_rate", "", 2.0 / 3.0, "fraction"),
         score("severity_accuracy", "", 0.5, "fraction"), score("time_to_detection", "mild", 12, "s"),
         score("time_to_detection", "severe", 20, "s"), score("case_time", "", 60, "s"),
         score("soft_tissue_time", "", 0.5, "s"), score("soft_tissue_peak_force", "", 1.2, "N"),
         score("enamel_excess_force_time", "", 0.0, "s"), score("enamel_peak_force", "", 3.0, "N"),
         score("blocked_insertions", "", 1, "count")});
    b.trial(
        "P2", "diagnosis", "diagnosis", 2, "2026-11-21T11:05:00.000Z", "2026-11-21T11:05:40.000Z",
        {score("lesions", "", 3, "count"), score("detected", "", 3, "count"), score("missed", "", 0, "count"),
         score("false_marks", "", 0, "count"), score("detection_rate", "", 1.0, "fraction"),
         score("severity_accuracy", "", 1.0, "fraction"), score("time_to_detection", "mild", 8, "s"),
         score("time_to_detection", "mild", 10, "s"), score("time_to_detection", "severe", 6, "s"),
         score("case_time", "", 40, "s"), score("soft_tissue_time", "", 0.0, "s"),
         score("soft_tissue_peak_force", "", 0.3, "N"), score("enamel_excess_force_time", "", 0.2, "s"),
         score("enamel_peak_force", "", 4.5, "N"), score("blocked_insertions", "", 2, "count")});
  }

  // The real figure script (apps/cariesim/plots/plot_report.py) with Debian's python3, as the
  // command runs it; empty when python3 with matplotlib is missing.
  static FigureDrawer python_figures() {
    return [](const fs::path& dir) {
      std::vector<fs::path> figures;
      const std::string script = std::string(CARIESIM_SOURCE_DIR) + "/apps/cariesim/plots/plot_report.py";
      if (test::run_command({"/usr/bin/python3", script, dir.string()}).status != 0) return figures;
      std::istringstream list(read_text(dir / "figures_report.txt"));
      for (std::string line; std::getline(list, line);)
        if (!line.empty()) figures.push_back(dir / line);
      fs::remove(dir / "figures_report.txt");
      return figures;
    };
  }

  static bool have_matplotlib() { return test::python3_imports("matplotlib"); }

  fs::path dir_;
};

// The numbers by hand (sample SD, n - 1):
//   Table 1, P1: mild mu_s {0.1, 0.2} = 0.15 ± 0.0707107; severe mu_s {0.5, 0.7} = 0.6 ± 0.141421;
//     mild mu_d {0.1, 0.2} = 0.15 ± 0.0707107; severe mu_d {0.4, 0.4} = 0.4 ± 0.
//   P2 (its unfinished trial 3 with 0.99 left out): mild mu_s 0.3 ± 0; severe mu_s {0.8, 0.9} = 0.85 ±
//   0.0707107. Cohort mild mu_s: means {0.15, 0.3} = 0.225 ± 0.106066; severe {0.6, 0.85} = 0.725 ± 0.176777.
//   ANOVA mu_s on the participant means: grand mean 0.475, SS_between = 2 (0.25^2) + 2 (0.25^2) = 0.25,
//     SS_within = 2 (0.075^2) + 2 (0.125^2) = 0.0425, F(1, 2) = 0.25 / (0.0425 / 2) = 11.7647059,
//     p = 1 - sqrt(F / (F + 2)) = 0.0754997 (scipy.stats.f_oneway: 0.07549967295795149).
//   ANOVA mu_d: mild {0.15, 0.2}, severe {0.4, 0.6}: SS_between 0.105625, SS_within 0.02125,
//     F(1, 2) = 9.9411765, p = 0.0875789 (scipy: 0.08757887175332464).
//   Boundary: P1 2 points of 3 trials (6.667 per 10), square 1, triangle 2/3, circle 1; P2 1 of 2
//     (5 per 10), square 0.5, triangle 1, circle 0.5; cohort points 1.5 ± 0.707107, per 10
//     5.8333 ± 1.178511.
//   Diagnosis, P2: lesions 6, detected 5, missed 1, false marks 1; detection rate {2/3, 1} =
//     0.83333 ± 0.235702; time to detection {12, 20, 8, 10, 6} = 11.2 ± 5.403702; mild {12, 8, 10} =
//     10 ± 2; severe {20, 6} = 13 ± 9.899495; case time {60, 40} = 50 ± 14.142136.
//   Safety, P2: soft-tissue time {0.5, 0} = 0.25 ± 0.353553; blocked insertions 1 + 2 = 3.
TEST_F(ReportTest, TwoStationsGiveTheTablesByHand) {
  make_two_stations();
  const Report report = build_report(merge_study_databases({dir_ / "station-a.db", dir_ / "station-b.db"}));
  EXPECT_EQ(report.merged.finished.size(), 11U);
  ASSERT_EQ(report.merged.unfinished.size(), 1U);
  EXPECT_EQ(report.merged.unfinished[0].trial, 3);
  EXPECT_TRUE(report.merged.duplicates.empty());
  const fs::path out = dir_ / "report";
  const ReportFiles files = write_report(report, out, python_figures());
  EXPECT_EQ(files.dir, fs::absolute(out));

  // Table 1.
  const auto t1 = read_csv(out / "table1_roughness.csv");
  ASSERT_EQ(t1.size(), 3U);
  const auto& p1 = row_of(t1, "participant", "P1");
  EXPECT_EQ(p1.at("trials"), "2");
  EXPECT_NEAR(num(p1, "mild_mu_s_mean"), 0.15, 1e-12);
  EXPECT_NEAR(num(p1, "mild_mu_s_sd"), 0.0707106781, 1e-9);
  EXPECT_NEAR(num(p1, "severe_mu_s_mean"), 0.6, 1e-12);
  EXPECT_NEAR(num(p1, "severe_mu_s_sd"), 0.1414213562, 1e-9);
  EXPECT_NEAR(num(p1, "severe_mu_d_sd"), 0.0, 1e-12);
  const auto& p2 = row_of(t1, "participant", "P2");
  EXPECT_EQ(p2.at("trials"), "2");  // the unfinished trial is not counted
  EXPECT_NEAR(num(p2, "mild_mu_s_mean"), 0.3, 1e-12);
  EXPECT_NEAR(num(p2, "severe_mu_s_mean"), 0.85, 1e-12);
  const auto& c1 = row_of(t1, "participant", "cohort");
  EXPECT_EQ(c1.at("trials"), "4");
  EXPECT_NEAR(num(c1, "mild_mu_s_mean"), 0.225, 1e-12);
  EXPECT_NEAR(num(c1, "mild_mu_s_sd"), 0.10606601717798213, 1e-12);
  EXPECT_NEAR(num(c1, "severe_mu_s_sd"), 0.1767766952966369, 1e-12);
  EXPECT_TRUE(read_csv(out / "table2_stiffness.csv").empty());

  // The ANOVA.
  const auto anova = read_csv(out / "anova.csv");
  ASSERT_EQ(anova.size(), 2U);  // no k_c, k_e in these databases
  const auto& mus = row_of(anova, "parameter", "mu_s");
  EXPECT_EQ(mus.at("df1"), "1");
  EXPECT_EQ(mus.at("df2"), "2");
  EXPECT_NEAR(num(mus, "ss_between"), 0.25, 1e-12);
  EXPECT_NEAR(num(mus, "ss_within"), 0.0425, 1e-12);
  EXPECT_NEAR(num(mus, "F"), 11.764705882352937, 1e-9);
  EXPECT_NEAR(num(mus, "p"), 0.07549967295795149, 1e-9);
  EXPECT_EQ(mus.at("significant"), "no");
  const auto& mud = row_of(anova, "parameter", "mu_d");
  EXPECT_NEAR(num(mud, "F"), 9.941176470588239, 1e-9);
  EXPECT_NEAR(num(mud, "p"), 0.08757887175332464, 1e-9);

  // The boundary score.
  const auto boundary = read_csv(out / "boundary.csv");
  ASSERT_EQ(boundary.size(), 3U);
  const auto& b1 = row_of(boundary, "participant", "P1");
  EXPECT_EQ(b1.at("trials"), "3");
  EXPECT_NEAR(num(b1, "points_mean"), 2.0, 1e-12);
  EXPECT_NEAR(num(b1, "points_per_10_mean"), 20.0 / 3.0, 1e-12);
  EXPECT_NEAR(num(b1, "shape_triangle_mean"), 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(num(b1, "shape_circle_mean"), 1.0, 1e-12);
  const auto& bc = row_of(boundary, "participant", "cohort");
  EXPECT_NEAR(num(bc, "points_mean"), 1.5, 1e-12);
  EXPECT_NEAR(num(bc, "points_sd"), 0.7071067811865476, 1e-12);
  EXPECT_NEAR(num(bc, "points_per_10_sd"), 1.1785113019775795, 1e-12);
  EXPECT_NEAR(num(bc, "shape_square_mean"), 0.75, 1e-12);

  // Diagnosis and safety.
  const auto diagnosis = read_csv(out / "diagnosis.csv");
  ASSERT_EQ(diagnosis.size(), 2U);
  const auto& d2 = row_of(diagnosis, "participant", "P2");
  EXPECT_EQ(d2.at("cases"), "2");
  EXPECT_NEAR(num(d2, "lesions"), 6, 1e-12);
  EXPECT_NEAR(num(d2, "detected"), 5, 1e-12);
  EXPECT_NEAR(num(d2, "missed"), 1, 1e-12);
  EXPECT_NEAR(num(d2, "false_marks"), 1, 1e-12);
  EXPECT_NEAR(num(d2, "detection_rate_mean"), 5.0 / 6.0, 1e-12);
  EXPECT_NEAR(num(d2, "detection_rate_sd"), 0.23570226039551587, 1e-12);
  EXPECT_NEAR(num(d2, "time_to_detection_s_mean"), 11.2, 1e-12);
  EXPECT_NEAR(num(d2, "time_to_detection_s_sd"), 5.403702434442518, 1e-12);
  EXPECT_NEAR(num(d2, "time_to_detection_mild_s_mean"), 10.0, 1e-12);
  EXPECT_NEAR(num(d2, "time_to_detection_mild_s_sd"), 2.0, 1e-12);
  EXPECT_NEAR(num(d2, "time_to_detection_severe_s_sd"), 9.899494936611665, 1e-12);
  EXPECT_NEAR(num(d2, "case_time_s_mean"), 50.0, 1e-12);
  const auto safety = read_csv(out / "safety.csv");
  const auto& s2 = row_of(safety, "participant", "P2");
  EXPECT_NEAR(num(s2, "soft_tissue_time_s_mean"), 0.25, 1e-12);
  EXPECT_NEAR(num(s2, "soft_tissue_time_s_sd"), 0.3535533905932738, 1e-12);
  EXPECT_NEAR(num(s2, "blocked_insertions"), 3.0, 1e-12);

  // Learning curve: P1's boundary trials in time order (1, 2, 3) score 3, 2, 3 shapes.
  std::vector<std::string> p1_curve;
  for (const auto& r : read_csv(out / "learning_curve.csv"))
    if (r.at("participant") == "P1" && r.at("kind") == "boundary-shapes")
      p1_curve.push_back(r.at("index") + ":" + r.at("trial") + ":" + r.at("value"));
  EXPECT_EQ(p1_curve, (std::vector<std::string>{"1:1:3", "2:2:2", "3:3:3"}));

  // Its summary: P1's {3, 2, 3} has slope 0 (sum (x - 2)(y - 8/3) = -1/3 + 0 + 1/3), P2's boundary
  // {1, 3} slope 2, P2's detection rate {2/3, 1} slope 1/3.
  const auto summary = read_csv(out / "learning_summary.csv");
  ASSERT_EQ(summary.size(), 6U);  // P1 boundary; P2 boundary; P2 diagnosis x 4 scores
  EXPECT_EQ(summary[0].at("participant"), "P1");
  EXPECT_EQ(summary[0].at("trials"), "3");
  EXPECT_NEAR(num(summary[0], "first"), 3.0, 1e-12);
  EXPECT_NEAR(num(summary[0], "last"), 3.0, 1e-12);
  EXPECT_NEAR(num(summary[0], "mean"), 8.0 / 3.0, 1e-12);
  EXPECT_NEAR(num(summary[0], "slope_per_trial"), 0.0, 1e-12);
  EXPECT_NEAR(num(summary[1], "slope_per_trial"), 2.0, 1e-12);
  EXPECT_EQ(summary[2].at("score"), "detection_rate");
  EXPECT_NEAR(num(summary[2], "slope_per_trial"), 1.0 / 3.0, 1e-12);

  // Unfinished trials are listed.
  const auto unfinished = read_csv(out / "unfinished.csv");
  ASSERT_EQ(unfinished.size(), 1U);
  EXPECT_EQ(unfinished[0].at("participant"), "P2");
  EXPECT_EQ(unfinished[0].at("station"), "station-b");

  // JSON holds the same numbers.
  const std::string json = read_text(out / "report.json");
  EXPECT_TRUE(has(json, "\"table1_roughness\":{"));
  EXPECT_TRUE(has(
      json, "\"participant\":\"cohort\",\"trials\":4,\"mild_mu_s_mean\":0.225,\"mild_mu_s_sd\":0.106066"));
  EXPECT_TRUE(has(json, "\"F\":11.7647,\"p\":0.0754997"));

  // HTML: the tables in the paper's layout, the figures embedded, nothing external.
  const std::string html = read_text(out / "report.html");
  EXPECT_TRUE(has(html, "Table 1: tuned friction coefficients"));
  EXPECT_TRUE(has(html,
                  "<td>P1</td><td>2</td><td>0.15 ± 0.07</td><td>0.15 ± 0.07</td><td>0.60 ± 0.14</td><td>0.40 "
                  "± 0.00</td>"));
  EXPECT_TRUE(has(html,
                  "<td>mu_s</td><td></td><td>0.225</td><td>0.725</td><td>2</td><td>2</td><td>0.2500</"
                  "td><td>0.0425</td><td>1</td><td>2</td><td>11.765</td><td>0.0755</td><td>no</td>"));
  EXPECT_TRUE(has(html, "<h3>Boundary shapes"));
  EXPECT_TRUE(has(html, "13 rows in learning_curve.csv and report.json."));
  EXPECT_TRUE(has(html, "1 unfinished trial(s)"));
  EXPECT_FALSE(has(html, "<script"));
  EXPECT_FALSE(has(html, "src=\"http"));
  EXPECT_FALSE(has(html, "href="));
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib is missing: figures not checked";
  EXPECT_EQ(files.figures, 4U);
  std::size_t images = 0;
  for (std::size_t at = html.find("src=\"data:image/png;base64,iVBORw0KGgo"); at != std::string::npos;
       at = html.find("src=\"data:image/png;base64,iVBORw0KGgo", at + 1))
    ++images;
  EXPECT_EQ(images, 4U);  // the PNG signature \x89PNG\r\n\x1a\n is "iVBORw0KGgo" in base64
  EXPECT_TRUE(fs::exists(out / "report-learning.png"));
}

// No file of a report holds NaN or infinity, even where F is undefined (zero variance within levels:
// every participant tuned the same values) and SDs of one trial do not exist.
TEST_F(ReportTest, UndefinedStatisticsAreLeftEmpty) {
  {
    StudyDbWriter a(dir_ / "a.db", "a");
    for (const char* who : {"P1", "P2"})
      for (int t = 1; t <= 2; ++t)
        a.trial(who, "tuning", "tuning", t, std::string("2026-11-20T09:0") + std::to_string(t) + ":00Z",
                "2026-11-20T09:30:00Z",
                {score("k_c", "mild", 0.6, "N/mm"), score("k_c", "severe", 0.2, "N/mm")});
    a.trial("P3", "tuning", "tuning", 1, "2026-11-20T10:00:00Z", "2026-11-20T10:30:00Z",
            {score("k_e", "mild", 0.5, "N/mm")});
  }
  const fs::path out = dir_ / "out";
  write_report(build_report(merge_study_databases({dir_ / "a.db"})), out, {});
  const auto anova = read_csv(out / "anova.csv");
  const auto& kc = row_of(anova, "parameter", "k_c");
  EXPECT_EQ(kc.at("F"), "");
  EXPECT_EQ(kc.at("p"), "");
  EXPECT_THAT(kc.at("note"), HasSubstr("zero variance"));
  const auto& ke = row_of(anova, "parameter", "k_e");
  EXPECT_THAT(ke.at("note"), HasSubstr("one group"));
  const auto t2 = read_csv(out / "table2_stiffness.csv");
  EXPECT_EQ(row_of(t2, "participant", "P3").at("mild_k_e_sd"), "");  // one trial: no SD
  EXPECT_THAT(read_text(out / "report.json"), HasSubstr("\"F\":null,\"p\":null"));
  for (const fs::directory_entry& e : fs::directory_iterator(out)) {
    const std::string text = read_text(e.path());
    for (const char* bad : {"nan", "NaN", "inf,", "inf\n", "Infinity"})
      EXPECT_FALSE(has(text, bad)) << e.path();
  }
  EXPECT_TRUE(has(read_text(out / "report.html"), "No figures"));
}

// The same database twice, a copy of it, and a copy taken while a trial was still running: every
// trial is counted once, the finished copy of the running one is kept, and each is reported.
TEST_F(ReportTest, DuplicatesAreCountedOnce) {
  make_two_stations();
  fs::copy_file(dir_ / "station-b.db", dir_ / "station-b-copy.db");
  // The copy's unfinished trial finished later on the station (its end time and a score changed).
  {
    io::Database copy(dir_ / "station-b-copy.db", SQLITE_OPEN_READWRITE);
    copy.exec("UPDATE trials SET ended_at = '2026-11-21T09:15:00Z' WHERE trial = 3 AND study = 'tuning'",
              "finish");
  }
  const fs::path link = dir_ / "again.db";
  fs::create_symlink(dir_ / "station-a.db", link);
  const MergedStudies merged =
      merge_study_databases({dir_ / "station-a.db", dir_ / "station-b.db", dir_ / "station-b-copy.db",
                             dir_ / "station-a.db", link});
  ASSERT_EQ(merged.inputs.size(), 5U);
  EXPECT_FALSE(merged.inputs[0].same_file_again);
  EXPECT_TRUE(merged.inputs[3].same_file_again);
  EXPECT_TRUE(merged.inputs[4].same_file_again);
  EXPECT_EQ(merged.inputs[2].trials, 7U);
  EXPECT_EQ(merged.inputs[2].duplicates, 7U);
  EXPECT_EQ(merged.finished.size(), 12U);  // 11, and the copy's finished trial 3
  EXPECT_TRUE(merged.unfinished.empty());
  ASSERT_EQ(merged.duplicates.size(), 7U);
  std::size_t differs = 0;
  for (const DuplicateTrial& d : merged.duplicates) {
    differs += d.differs ? 1 : 0;
    if (d.differs) {
      EXPECT_THAT(d.kept, HasSubstr("station-b-copy.db#"));
      EXPECT_THAT(d.dropped, HasSubstr("station-b.db#"));
    }
  }
  EXPECT_EQ(differs, 1U);

  const Report report = build_report(merged);
  ASSERT_FALSE(report.warnings.empty());
  EXPECT_THAT(report.warnings[0], HasSubstr("given twice"));
  const fs::path out = dir_ / "out";
  write_report(report, out, {});
  EXPECT_EQ(read_csv(out / "duplicates.csv").size(), 7U);
  // The boundary table is the same as from the two stations alone: nothing counted twice.
  const auto boundary = read_csv(out / "boundary.csv");
  EXPECT_EQ(row_of(boundary, "participant", "P2").at("trials"), "2");
  EXPECT_NEAR(num(row_of(boundary, "participant", "cohort"), "points_mean"), 1.5, 1e-12);
  EXPECT_EQ(
      row_of(read_csv(out / "inputs.csv"), "file", (dir_ / "station-b-copy.db").string()).at("duplicates"),
      "7");
}

// Bad inputs: each error names the file and what is wrong, and the databases are left as they were.
TEST_F(ReportTest, BadInputsAreRefusedNamingTheFile) {
  make_two_stations();
  auto error_of = [](const std::vector<fs::path>& files) {
    try {
      merge_study_databases(files);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const fs::path missing = dir_ / "missing.db";
  EXPECT_THAT(error_of({dir_ / "station-a.db", missing}),
              HasSubstr(missing.string() + ": no such study database"));

  const fs::path text = dir_ / "notes.txt";
  std::ofstream(text) << "this is not a database, it is a note about the class\n";
  EXPECT_THAT(error_of({text}), HasSubstr(text.string() + ": not a study database"));

  const fs::path other = dir_ / "other.db";
  {
    io::Database db(other, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    db.exec("CREATE TABLE patients (name TEXT)", "create");
  }
  EXPECT_THAT(error_of({other}), HasSubstr(other.string() + ": not a study database (application id 0"));

  const fs::path recording = dir_ / "recording.db";
  { StudyDbWriter w(recording, "x", 1, 0x4352534D); }
  EXPECT_THAT(error_of({recording}), HasSubstr("a cariesim session recording"));

  const fs::path newer = dir_ / "newer.db";
  { StudyDbWriter w(newer, "x", kStudySchemaVersion + 1); }
  EXPECT_THAT(error_of({newer}),
              HasSubstr(newer.string() + ": study database schema version 3 is newer than"));

  const fs::path older = dir_ / "older.db";
  { StudyDbWriter w(older, "x", 0); }
  EXPECT_THAT(error_of({older}), HasSubstr("schema version 0 is not supported"));

  const fs::path no_version = dir_ / "no-version.db";
  {
    StudyDbWriter w(no_version, "x");
    w.db().exec("DELETE FROM schema_version", "empty the version table");
  }
  EXPECT_THAT(error_of({no_version}), HasSubstr("schema_version has no row"));

  const fs::path folder = dir_ / "folder.db";
  fs::create_directory(folder);
  EXPECT_THAT(error_of({folder}), HasSubstr("is a folder"));

  // An orphan score (a trial id the trials table lacks) is named with its file.
  const fs::path orphan = dir_ / "orphan.db";
  {
    StudyDbWriter w(orphan, "x");
    w.db().exec(
        "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (99, 'mu_s', 'mild', 0.2, '')",
        "orphan");
  }
  EXPECT_THAT(error_of({orphan}), HasSubstr(orphan.string() + ": scores: a score of trial id 99"));

  // Reading changed no byte of the databases.
  const std::string before = read_text(dir_ / "station-a.db");
  merge_study_databases({dir_ / "station-a.db"});
  EXPECT_EQ(read_text(dir_ / "station-a.db"), before);
}

// A report that fails keeps the earlier one in place; one that succeeds replaces its files.
TEST_F(ReportTest, AFailedWriteKeepsTheEarlierReport) {
  make_two_stations();
  const fs::path out = dir_ / "out";
  const Report report = build_report(merge_study_databases({dir_ / "station-a.db"}));
  write_report(report, out, {});
  const std::string earlier = read_text(out / "report.html");
  ASSERT_THAT(earlier, HasSubstr("P1"));
  // The figure drawer fails half-way: nothing of the new report reaches `out`.
  const Report both = build_report(merge_study_databases({dir_ / "station-a.db", dir_ / "station-b.db"}));
  EXPECT_THROW(
      write_report(both, out,
                   [](const fs::path&) -> std::vector<fs::path> { throw Error("figure drawer failed"); }),
      Error);
  EXPECT_EQ(read_text(out / "report.html"), earlier);
  for (const fs::directory_entry& e : fs::directory_iterator(dir_))
    EXPECT_THAT(e.path().filename().string(), Not(HasSubstr(".report-"))) << "staging folder left behind";
  write_report(both, out, {});
  EXPECT_THAT(read_text(out / "report.html"), HasSubstr("P2"));
  // A file in the way of the folder is an error naming it.
  std::ofstream(dir_ / "file") << "x";
  EXPECT_THROW(write_report(both, dir_ / "file", {}), Error);
}

// Issue 26 items 7 and 16: a name or level from a station database reaches the tables as it is.
// A column key `evil,"x"\n=1+2` split the CSV header into three columns and put a formula on the
// next line; a text cell "=1+2" ran as a formula in a spreadsheet; invalid UTF-8 made report.json
// invalid JSON. The CSV keeps one field per key and cell (RFC 4180) with formula-leading text
// neutralised (numbers untouched); report.json replaces invalid UTF-8 with U+FFFD.
TEST_F(ReportTest, HostileNamesStayCellsAndReportJsonStaysJson) {
  const std::string evil = "evil,\"x\"\n=1+2";
  Report report;
  ReportTable table;
  table.name = "crafted";
  table.title = "Crafted";
  table.columns = {{"participant", "Participant", 0}, {evil, "Evil", 3}};
  table.rows = {{Cell::of_text("=1+2"), Cell::of_number(-0.5)},
                {Cell::of_text("@SUM(A1:A9)"), Cell::of_integer(-3)},
                {Cell::of_text("bad\xFF\xFEname"), Cell::of_text("-cmd")}};
  report.tables.push_back(table);
  const fs::path out = dir_ / "out";
  write_report(report, out, {});

  const auto rows = test::parse_rfc4180(read_text(out / "crafted.csv"));
  ASSERT_EQ(rows.size(), 4u) << read_text(out / "crafted.csv");
  EXPECT_EQ(rows[0], (std::vector<std::string>{"participant", evil}));
  EXPECT_EQ(rows[1], (std::vector<std::string>{"'=1+2", "-0.5"}));
  EXPECT_EQ(rows[2], (std::vector<std::string>{"'@SUM(A1:A9)", "-3"}));
  EXPECT_EQ(rows[3][1], "'-cmd");

  const std::string json = read_text(out / "report.json");
  EXPECT_EQ(json.find("\xFF"), std::string::npos);
  EXPECT_THAT(json, HasSubstr("bad\xEF\xBF\xBD\xEF\xBF\xBDname"));
  // Python's json module (strict UTF-8) reads it back.
  const test::CommandOutput check =
      test::run_command({"/usr/bin/python3", "-c", "import json,sys; json.load(open(sys.argv[1], encoding='utf-8'))",
                         (out / "report.json").string()});
  EXPECT_EQ(check.status, 0) << "report.json is not valid JSON in UTF-8: " << check.err;
}

// --- The gradebook (docs/reports.md, "The gradebook") ---

// A diagnosis case's scores as a station writes them for `found` of three lesions, `false_marks`
// false marks and the detection times `times` (s, mild, severe, mild order of the lesions found).
std::vector<TrialScore> case_scores(int found, int false_marks, double accuracy,
                                    const std::vector<std::pair<const char*, double>>& times,
                                    double soft_tissue) {
  std::vector<TrialScore> s = {score("lesions", "", 3, "count"),
                               score("detected", "", found, "count"),
                               score("missed", "", 3 - found, "count"),
                               score("false_marks", "", false_marks, "count"),
                               score("detection_rate", "", found / 3.0, "fraction"),
                               score("case_time", "", 90, "s"),
                               score("soft_tissue_time", "", soft_tissue, "s"),
                               score("soft_tissue_peak_force", "", 1.5, "N"),
                               score("enamel_excess_force_time", "", 0.0, "s"),
                               score("enamel_peak_force", "", 2.0, "N"),
                               score("blocked_insertions", "", 0, "count")};
  if (found > 0) s.push_back(score("severity_accuracy", "", accuracy, "fraction"));
  for (const auto& [level, t] : times) s.push_back(score("time_to_detection", level, t, "s"));
  return s;
}

// The answers of the paper's case (#1 severe, #2 severe, #3 mild): lesion 1 found at 12 s graded
// severe (right), lesion 3 found at 40 s graded severe (wrong), a second mark on lesion 1 (neither
// counts), a false mark at 50 s; lesion 2 missed.
constexpr const char* kPaperCaseAnswers =
    R"({"lesions":[{"site":"46-occlusal-fossa","severity":"severe","size":2.2,"width":0,"depth":2.5},)"
    R"({"site":"46-mesial","severity":"severe","size":2,"width":1.4,"depth":1.3},)"
    R"({"site":"36-occlusal-fossa","severity":"mild","size":3,"width":0.8,"depth":1.2}],)"
    R"("marks":[{"t":12,"grade":"severe","contact":true,"tip":[1,2,3],"lesion":1,"distance":0,"first":true},)"
    R"({"t":20,"grade":"mild","contact":true,"tip":[1,2,3],"lesion":1,"distance":0,"first":false},)"
    R"({"t":40,"grade":"severe","contact":true,"tip":[4,5,6],"lesion":3,"distance":0.2,"first":true},)"
    R"({"t":50,"grade":"mild","contact":true,"tip":[9,9,9],"lesion":null,"distance":3.5,"first":false}],)"
    R"("ended_at":90})";

// Each lesion of each case is a row, found or missed, with its grade and time; false marks follow;
// each case has its summary in words. (Main had only per-participant sums.)
TEST_F(ReportTest, GradebookListsEachLesionFoundOrMissed) {
  {
    StudyDbWriter a(dir_ / "a.db", "chair-1");
    a.trial("P1", "diagnosis", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
            case_scores(2, 1, 0.5, {{"severe", 12}, {"mild", 40}}, 0.4), 42, kPaperCaseAnswers);
  }
  const fs::path out = dir_ / "out";
  write_report(build_report(merge_study_databases({dir_ / "a.db"})), out, {});
  const auto lesions = read_csv(out / "lesions.csv");
  ASSERT_EQ(lesions.size(), 4U);  // three lesions and one false mark
  EXPECT_EQ(lesions[0].at("site"), "46-occlusal-fossa");
  EXPECT_EQ(lesions[0].at("result"), "found");
  EXPECT_EQ(lesions[0].at("marked_as"), "severe");
  EXPECT_EQ(lesions[0].at("grade"), "right");
  EXPECT_EQ(lesions[0].at("time_s"), "12");
  EXPECT_EQ(lesions[1].at("site"), "46-mesial");
  EXPECT_EQ(lesions[1].at("result"), "missed");
  EXPECT_EQ(lesions[1].at("time_s"), "");
  EXPECT_EQ(lesions[2].at("result"), "found");
  EXPECT_EQ(lesions[2].at("grade"), "wrong");
  EXPECT_EQ(lesions[2].at("time_s"), "40");
  EXPECT_EQ(lesions[3].at("result"), "false mark");
  EXPECT_EQ(lesions[3].at("time_s"), "50");

  const std::string cases = read_text(out / "cases.csv");
  EXPECT_TRUE(has(cases,
                  "Found 2 of 3 lesions (1 graded wrong); 1 false mark. Pressed on gum or tongue "
                  "for 0.40 s (up to 1.5 N)."));
  const auto case_rows = read_csv(out / "cases.csv");
  ASSERT_EQ(case_rows.size(), 1U);
  EXPECT_EQ(case_rows[0].at("time_per_lesion_s"), "26");  // (12 + 40) / 2
  const std::string html = read_text(out / "report.html");
  EXPECT_TRUE(has(html, "<h2>Gradebook</h2>"));
  EXPECT_TRUE(has(html, "<td>missed</td>"));
}

// The case pictures' data are drawn from the model: the built-in diagnosis-paper study's first case rebuilt from the
// recorded seed places the paper's three lesions on the real-arch teeth (46 occlusal and mesial, 36
// occlusal, snapped as the model builder snaps them), every tooth has an outline seen from above; a
// recorded case the rebuild does not give keeps its marks, without lesions, and a warning says so.
TEST_F(ReportTest, CasePicturesPlaceTheLesionsWhereTheModelDoes) {
  {
    StudyDbWriter a(dir_ / "a.db", "chair-1");
    a.trial("P1", "diagnosis-paper", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
            case_scores(2, 1, 0.5, {{"severe", 12}, {"mild", 40}}, 0.4), 42, kPaperCaseAnswers);
    std::string other = kPaperCaseAnswers;
    other.replace(other.find("46-occlusal-fossa"), 17, "47-occlusal-fossa");
    a.trial("P1", "diagnosis-paper", "diagnosis", 1, "2026-11-20T12:00:00Z", "2026-11-20T12:02:00Z",
            case_scores(2, 1, 0.5, {{"severe", 12}, {"mild", 40}}, 0.4), 43, other);
  }
  Report report = build_report(merge_study_databases({dir_ / "a.db"}));
  EXPECT_EQ(add_case_views(report, {}), 2U);
  const fs::path out = dir_ / "out";
  write_report(report, out, {});
  const auto points = read_csv(out / "case_points.csv");
  std::vector<std::map<std::string, std::string>> lesions;
  for (const auto& r : points)
    if (r.at("what") == "lesion") lesions.push_back(r);
  ASSERT_EQ(lesions.size(), 3U);  // the second case's lesions are not drawn
  for (const auto& r : lesions) EXPECT_EQ(r.at("case"), "1");
  // 46 is on the left of the arch's picture (x < 0), 36 on the right; the mesial lesion of 46 lies
  // toward 45 (lower y) than its occlusal one.
  EXPECT_LT(num(lesions[0], "x_mm"), -15.0);
  EXPECT_LT(num(lesions[1], "y_mm"), num(lesions[0], "y_mm") - 2.0);
  EXPECT_GT(num(lesions[2], "x_mm"), 15.0);
  EXPECT_EQ(lesions[0].at("result"), "found");
  EXPECT_EQ(lesions[1].at("result"), "missed");
  EXPECT_EQ(lesions[0].at("size_mm"), "2.2");
  std::size_t marks = 0;
  for (const auto& r : points) marks += r.at("what") == "mark" ? 1 : 0;
  EXPECT_EQ(marks, 8U);  // both cases' four marks
  std::set<std::string> teeth;
  for (const auto& r : read_csv(out / "case_outlines.csv")) teeth.insert(r.at("tooth"));
  EXPECT_EQ(teeth.size(), 16U);
  ASSERT_FALSE(report.warnings.empty());
  EXPECT_THAT(report.warnings.back(), HasSubstr("1 case picture(s) without their lesions: P1 case 2"));
  EXPECT_FALSE(has(read_text(out / "report.html"), "case_points"));  // data for the figure only
}

// A course's criteria grade each trainee: gradebook.csv holds one row per trainee and criterion (and
// `overall`), passed.csv who passed; text from a database is a neutralised cell there too.
TEST_F(ReportTest, CriteriaGradeEachTraineePassOrFail) {
  {
    StudyDbWriter a(dir_ / "a.db", "chair-1");
    // Good: every lesion of both cases found in under 30 s on average, graded right, no false mark.
    a.trial("Good", "diagnosis", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
            case_scores(3, 0, 1.0, {{"severe", 10}, {"severe", 20}, {"mild", 30}}, 0.0));
    a.trial("Good", "diagnosis", "diagnosis", 2, "2026-11-20T11:05:00Z", "2026-11-20T11:07:00Z",
            case_scores(3, 0, 1.0, {{"severe", 15}, {"severe", 25}, {"mild", 35}}, 0.2));
    // =Weak (a formula-leading name): 4 of 6 found, a false mark, 45 s per lesion, 2 s on the gum.
    a.trial("=Weak", "diagnosis", "diagnosis", 1, "2026-11-20T12:00:00Z", "2026-11-20T12:02:00Z",
            case_scores(2, 1, 1.0, {{"severe", 40}, {"mild", 50}}, 2.0));
    a.trial("=Weak", "diagnosis", "diagnosis", 2, "2026-11-20T12:05:00Z", "2026-11-20T12:07:00Z",
            case_scores(2, 0, 0.5, {{"severe", 40}, {"mild", 50}}, 0.1));
  }
  PassCriteria criteria;
  criteria.detection_rate = 1.0;
  criteria.false_marks = 0;
  criteria.time_per_lesion = 30.0;
  criteria.soft_tissue_time = 1.0;
  const fs::path out = dir_ / "out";
  write_report(build_report(merge_study_databases({dir_ / "a.db"}), &criteria), out, {});

  const auto book = test::parse_rfc4180(read_text(out / "gradebook.csv"));
  ASSERT_EQ(book.size(), 1U + 2U * 6U) << read_text(out / "gradebook.csv");  // header, 2 x (5 + overall)
  EXPECT_EQ(book[0], (std::vector<std::string>{"participant", "criterion", "definition", "value", "required",
                                               "expert", "result", "note"}));
  // Rows by participant: "=Weak" sorts before "Good"; its name is neutralised.
  auto row = [&](const std::string& who, const std::string& criterion) {
    for (const auto& r : book)
      if (r[0] == who && r[1] == criterion) return r;
    ADD_FAILURE() << "no row " << who << " " << criterion;
    return std::vector<std::string>(8);
  };
  EXPECT_EQ(row("'=Weak", "detection_rate")[3], "0.6666666666666666");
  EXPECT_EQ(row("'=Weak", "detection_rate")[4], "at least 1");
  EXPECT_EQ(row("'=Weak", "detection_rate")[6], "fail");
  EXPECT_THAT(row("'=Weak", "detection_rate")[5], HasSubstr("every lesion"));
  EXPECT_EQ(row("'=Weak", "false_marks")[6], "fail");
  EXPECT_EQ(row("'=Weak", "time_per_lesion")[3], "45");
  EXPECT_EQ(row("'=Weak", "time_per_lesion")[6], "fail");
  EXPECT_THAT(row("'=Weak", "time_per_lesion")[5], HasSubstr("under 30 s"));
  EXPECT_EQ(row("'=Weak", "soft_tissue_time")[6], "fail");
  EXPECT_EQ(row("'=Weak", "severity_accuracy")[6], "");      // not a criterion of this course
  EXPECT_EQ(row("'=Weak", "severity_accuracy")[3], "0.75");  // 3 of the 4 found graded right
  EXPECT_EQ(row("'=Weak", "overall")[6], "fail");
  EXPECT_EQ(row("Good", "detection_rate")[6], "pass");
  EXPECT_EQ(row("Good", "time_per_lesion")[3], "22.5");
  EXPECT_EQ(row("Good", "time_per_lesion")[6], "pass");
  EXPECT_EQ(row("Good", "soft_tissue_time")[3], "0.2");
  EXPECT_EQ(row("Good", "overall")[6], "pass");

  const auto passed = test::parse_rfc4180(read_text(out / "passed.csv"));
  ASSERT_EQ(passed.size(), 3U);
  EXPECT_EQ(passed[1][0], "'=Weak");
  EXPECT_EQ(passed[1][4], "fail");
  EXPECT_EQ(passed[1][5], "detection_rate, false_marks, time_per_lesion, soft_tissue_time");
  EXPECT_EQ(passed[2][0], "Good");
  EXPECT_EQ(passed[2][4], "pass");
  EXPECT_TRUE(has(read_text(out / "report.html"), "<h3>Who passed</h3>"));

  // Without criteria: the values and the expert's figures, no verdict.
  const fs::path plain = dir_ / "plain";
  write_report(build_report(merge_study_databases({dir_ / "a.db"})), plain, {});
  const auto ungraded = test::parse_rfc4180(read_text(plain / "gradebook.csv"));
  EXPECT_EQ(ungraded.size(), 1U + 2U * 5U);
  for (std::size_t i = 1; i < ungraded.size(); ++i) EXPECT_EQ(ungraded[i][6], "") << i;
  EXPECT_TRUE(has(read_text(plain / "report.html"), "No pass/fail"));
}

// A study without tuning or boundary data has no such tables on the page (main wrote "No data."
// under each), the research section holds only what exists, and each score has its definition.
TEST_F(ReportTest, TablesWithoutDataAreLeftOffThePage) {
  {
    StudyDbWriter a(dir_ / "a.db", "chair-1");
    a.trial("P1", "diagnosis", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
            case_scores(3, 0, 1.0, {{"severe", 10}, {"severe", 20}, {"mild", 30}}, 0.0));
  }
  const fs::path out = dir_ / "out";
  write_report(build_report(merge_study_databases({dir_ / "a.db"})), out, {});
  const std::string html = read_text(out / "report.html");
  EXPECT_FALSE(has(html, "No data."));
  for (const char* absent : {"Table 1:", "Table 2:", "One-way ANOVA", "Boundary shapes", "Unfinished trials",
                             "Duplicate trial rows"})
    EXPECT_FALSE(has(html, absent)) << absent;
  EXPECT_TRUE(has(html, "<h2>Research tables</h2>"));
  EXPECT_TRUE(has(html, "Diagnosis"));
  // Their CSVs stay (empty), for scripts that read them.
  EXPECT_TRUE(fs::exists(out / "table1_roughness.csv"));
  // Every score shown is defined on the page, in the order the gradebook shows them first.
  EXPECT_TRUE(has(html, "<dt>blocked insertions</dt><dd>pushes on caries that did not enter"));
  EXPECT_TRUE(has(html, "<dt>enamel peak</dt>"));
  EXPECT_TRUE(has(html, "<dt>soft-tissue time</dt>"));
  EXPECT_TRUE(has(read_text(out / "report.json"), "\"definitions\":[{\"term\":"));
  EXPECT_LT(html.find("<h2>Gradebook</h2>"), html.find("<h2>Research tables</h2>"));
}

// A case's answers from a station are hostile input like its scores: every field is checked, and a
// bad one is refused naming the file, the row, the column and the field; deep nesting is refused,
// not recursed into.
TEST_F(ReportTest, HostileCaseAnswersAreRefusedNamingTheField) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"lesions":[{"site":"x","severity":"evil"}],"marks":[]})", "lesions[0].severity"},
      {R"({"lesions":[{"site":"x","severity":"mild"}],"marks":[{"t":1,"grade":"mild","contact":true,)"
       R"("tip":[0,0,0],"lesion":7,"first":true}]})",
       "marks[0].lesion"},
      {R"({"lesions":[{"site":"x","severity":"mild"}],"marks":[{"t":1e400,"grade":"mild","contact":true,)"
       R"("tip":[0,0,0],"lesion":null}]})",
       "marks[0].t"},
      {R"({"lesions":[{"site":"x","severity":"mild"}],"marks":[{"t":1,"grade":"mild","contact":true,)"
       R"("tip":[0,0,1e300],"lesion":null}]})",
       "marks[0].tip"},
      {R"({"lesions":[{"site":"x","severity":"mild"}],"marks":[)"
       R"({"t":1,"grade":"mild","contact":true,"tip":[0,0,0],"lesion":1,"first":true},)"
       R"({"t":2,"grade":"mild","contact":true,"tip":[0,0,0],"lesion":1,"first":true}]})",
       "marks[1].first"},
      {R"({"lesions":[{"site":"x","severity":"mild"}]})", "marks"},
      {R"([1, 2])", "answers"},
      {std::string(100000, '[') + std::string(100000, ']'), "YAML syntax error"},
  };
  for (std::size_t i = 0; i < bad.size(); ++i) {
    const fs::path db = dir_ / ("bad" + std::to_string(i) + ".db");
    {
      StudyDbWriter a(db, "chair-1");
      a.trial("P1", "diagnosis", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
              case_scores(0, 0, 0, {}, 0.0), 42, bad[i].first);
    }
    try {
      (void)merge_study_databases({db});
      ADD_FAILURE() << "accepted: " << bad[i].first.substr(0, 200);
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(db.string() + ": trials, row 1, column answers")) << i;
      EXPECT_THAT(e.what(), HasSubstr(bad[i].second)) << i;
    }
  }
}

// The figures: every legend entry has data (main drew a "mild" entry without bars when no mild lesion
// was found), checked by running plot_report.py with matplotlib's savefig recording each legend's
// entries and the data drawn for them.
TEST_F(ReportTest, EveryLegendEntryOfTheFiguresHasData) {
  if (!have_matplotlib()) GTEST_SKIP() << "/usr/bin/python3 with matplotlib is missing";
  {
    StudyDbWriter a(dir_ / "a.db", "chair-1");
    // Only severe lesions found, by both trainees: no mild time to detection exists.
    for (const char* who : {"P1", "P2"})
      a.trial(who, "diagnosis", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
              case_scores(1, 0, 1.0, {{"severe", 10}}, 0.0));
  }
  const fs::path out = dir_ / "out";
  write_report(build_report(merge_study_databases({dir_ / "a.db"})), out, {});
  // A legend entry has data when its bars include one of non-zero height, or its line has points.
  const std::string check = R"(
import runpy, sys
import matplotlib
matplotlib.use("Agg")
from matplotlib.figure import Figure
from matplotlib.container import BarContainer
empty = []
real = Figure.savefig
def savefig(self, name, *a, **k):
    for ax in self.axes:
        legend = ax.get_legend()
        if legend is None: continue
        labels = [t.get_text() for t in legend.get_texts()]
        drawn = {c.get_label(): c for c in ax.containers}
        drawn.update({l.get_label(): l for l in ax.lines})
        for label in labels:
            c = drawn.get(label)
            if isinstance(c, BarContainer):
                ok = any(p.get_height() > 0 for p in c.patches)
            elif c is not None and hasattr(c, "get_xdata"):
                ok = len(c.get_xdata()) > 0
            else:
                ok = c is not None
            if not ok: empty.append("%s: %s" % (name, label))
    return real(self, name, *a, **k)
Figure.savefig = savefig
sys.argv = ["plot_report.py", sys.argv[1]]
runpy.run_path(SCRIPT, run_name="__main__")
print("EMPTY:" + "|".join(empty))
)";
  const std::string script = std::string(CARIESIM_SOURCE_DIR) + "/apps/cariesim/plots/plot_report.py";
  std::string code = check;
  code.replace(code.find("SCRIPT"), 6, "'" + script + "'");
  const test::CommandOutput r = test::run_command({"/usr/bin/python3", "-c", code, out.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("EMPTY:\n")) << r.out;
  EXPECT_TRUE(fs::exists(out / "report-diagnosis.png"));
}

TEST(ReportBase64, Rfc4648Vectors) {
  // RFC 4648 §10.
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foob"), "Zm9vYg==");
  EXPECT_EQ(base64_encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_encode(std::string("\x89PNG\r\n\x1a\n", 8)), "iVBORw0KGgo=");
}

}  // namespace
}  // namespace cariesim::training
