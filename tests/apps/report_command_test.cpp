// `cariesim report DB... --out DIR` on two stations' study databases, and on bad input.
#include <fcntl.h>
#include <grp.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "apps/apps_support.hpp"
#include "support/command.hpp"
#include "support/csv.hpp"
#include "support/files.hpp"
#include "training/study_db_support.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using training::TrialScore;

class ReportCommand : public test::ScratchTest {
 protected:
  ReportCommand() : ScratchTest("cariesim_report_cmd_") {}

  // P1 at station-a and P2 at station-b, two tuning trials each; station-b also has an unfinished one.
  void make_stations() {
    test::StudyDbWriter a(dir_ / "station-a.db", "station-a");
    a.trial("P1", "tuning", "tuning", 1, "2026-11-20T09:00:00Z", "2026-11-20T09:05:00Z",
            {{"mu_s", "mild", 0.1, ""}, {"mu_s", "severe", 0.5, ""}});
    a.trial("P1", "tuning", "tuning", 2, "2026-11-20T09:05:00Z", "2026-11-20T09:10:00Z",
            {{"mu_s", "mild", 0.2, ""}, {"mu_s", "severe", 0.7, ""}});
    test::StudyDbWriter b(dir_ / "station-b.db", "station-b");
    b.trial("P2", "tuning", "tuning", 1, "2026-11-21T09:00:00Z", "2026-11-21T09:05:00Z",
            {{"mu_s", "mild", 0.3, ""}, {"mu_s", "severe", 0.8, ""}});
    b.trial("P2", "tuning", "tuning", 2, "2026-11-21T09:05:00Z", "2026-11-21T09:10:00Z",
            {{"mu_s", "mild", 0.3, ""}, {"mu_s", "severe", 0.9, ""}});
    b.trial("P2", "tuning", "tuning", 3, "2026-11-21T09:10:00Z", std::nullopt, {{"mu_s", "mild", 0.99, ""}});
  }

  std::string dbs() const {
    return "'" + (dir_ / "station-a.db").string() + "' '" + (dir_ / "station-b.db").string() + "'";
  }
};

// The figures through the embedded plot_report.py, the same F(1, 2) = 11.7647 as the library test
// (tests/training/report_test.cpp: mild {0.15, 0.3}, severe {0.6, 0.85}).
TEST_F(ReportCommand, WritesTheReport) {
  make_stations();
  const fs::path out = dir_ / "report";
  const test::CommandResult r = test::run_cariesim("report " + dbs() + " --out '" + out.string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("2 database(s), 4 finished trial(s), 1 unfinished"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("warning: 1 unfinished trial(s)"), std::string::npos) << r.err;
  for (const char* f : {"report.html", "report.json", "table1_roughness.csv", "anova.csv", "boundary.csv",
                        "diagnosis.csv", "safety.csv", "learning_curve.csv", "unfinished.csv",
                        "duplicates.csv", "inputs.csv", "table2_stiffness.csv"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  const std::string anova = read_text(out / "anova.csv");
  EXPECT_NE(anova.find(",1,2,11.76470588235"), std::string::npos) << anova;  // df1, df2, F
  EXPECT_NE(anova.find(",0.0754996729579"), std::string::npos) << anova;     // p
  const std::string html = read_text(out / "report.html");
  EXPECT_EQ(html.find("<script"), std::string::npos);
  if (!test::python3_imports("matplotlib"))
    GTEST_SKIP() << "/usr/bin/python3 with matplotlib is missing: figures not checked";
  EXPECT_NE(r.err.find("(1 figure(s))"), std::string::npos)
      << r.err;  // tuning only: no boundary or diagnosis
  EXPECT_NE(html.find("src=\"data:image/png;base64,iVBORw0KGgo"), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "report-tuning.png"));
}

TEST_F(ReportCommand, NoFigures) {
  make_stations();
  const fs::path out = dir_ / "report";
  const test::CommandResult r =
      test::run_cariesim("report " + dbs() + " --out '" + out.string() + "' --no-figures --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  EXPECT_FALSE(fs::exists(out / "report-tuning.png"));
  EXPECT_NE(read_text(out / "report.html").find("No figures"), std::string::npos);
}

// docs/reports.md's example runs as written: examples/make_example_study.py (which reads the schema
// from src/training/study_schema.hpp) and the report of its two stations.
TEST_F(ReportCommand, DocumentedExampleRuns) {
  if (!test::python3_imports("sqlite3"))
    GTEST_SKIP() << "/usr/bin/python3 is missing";
  const std::string script = std::string(CARIESIM_SOURCE_DIR) + "/examples/make_example_study.py";
  const test::CommandOutput made = test::run_command({"/usr/bin/python3", script, (dir_ / "class").string()});
  ASSERT_EQ(made.status, 0) << made.how << "\n" << made.err;
  const fs::path out = dir_ / "class" / "report";
  const test::CommandResult r = test::run_cariesim(
      "report '" + (dir_ / "class" / "station-a.db").string() + "' '" +
      (dir_ / "class" / "station-b.db").string() + "' --course '" +
      (dir_ / "class" / "course.yaml").string() + "' --out '" + out.string() + "' --no-figures");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("report: 2 database(s), 90 finished trial(s), 1 unfinished, 0 duplicate row(s)"),
            std::string::npos)
      << r.err;
  // Five dentists in both tables and an F(1, 8) per parameter, as in the paper.
  const std::string anova = read_text(out / "anova.csv");
  for (const char* parameter : {"mu_s,", "mu_d,", "k_c,", "k_e,"})
    EXPECT_NE(anova.find(std::string(parameter)), std::string::npos) << anova;
  EXPECT_NE(anova.find(",5,5,"), std::string::npos) << anova;
  EXPECT_NE(anova.find(",1,8,"), std::string::npos) << anova;
  // The gradebook: five dentists x (four criteria of the example's course + overall), each with a
  // verdict; twelve lesions per dentist, listed one by one.
  const auto book = test::parse_rfc4180(read_text(out / "gradebook.csv"));
  ASSERT_EQ(book.size(), 1U + 5U * 6U);
  for (std::size_t i = 1; i < book.size(); ++i)
    if (book[i][1] != "severity_accuracy") {
      EXPECT_TRUE(book[i][6] == "pass" || book[i][6] == "fail") << i;
    }
  const auto passed = test::parse_rfc4180(read_text(out / "passed.csv"));
  ASSERT_EQ(passed.size(), 6U);
  std::size_t lesion_rows = 0;
  for (const auto& row : test::parse_rfc4180(read_text(out / "lesions.csv")))
    lesion_rows += (row[5] == "found" || row[5] == "missed") ? 1 : 0;
  EXPECT_EQ(lesion_rows, 5U * 4U * 3U);

  // As docs/reports.md runs it, with the figures: one case picture per dentist (the paper's case
  // rebuilt from the built-in study: every lesion placed), the four figures of the research tables.
  if (!test::python3_imports("matplotlib")) GTEST_SKIP() << "/usr/bin/python3 with matplotlib is missing";
  const fs::path drawn = dir_ / "class" / "drawn";
  const test::CommandResult f =
      test::run_cariesim("report '" + (dir_ / "class" / "station-a.db").string() + "' '" +
                         (dir_ / "class" / "station-b.db").string() + "' --course '" +
                         (dir_ / "class" / "course.yaml").string() + "' --out '" + drawn.string() + "'");
  ASSERT_EQ(f.status, 0) << f.err;
  EXPECT_NE(f.err.find("(9 figure(s))"), std::string::npos) << f.err;
  EXPECT_EQ(f.err.find("case picture(s) without their lesions"), std::string::npos) << f.err;
  for (int i = 1; i <= 5; ++i)
    EXPECT_TRUE(fs::exists(drawn / ("report-cases-" + std::to_string(i) + ".png"))) << i;
  std::size_t placed = 0;
  for (const auto& row : test::parse_rfc4180(read_text(drawn / "case_points.csv")))
    placed += row[3] == "lesion" ? 1 : 0;
  EXPECT_EQ(placed, 5U * 4U * 3U);
}

// `--course` grades with the course's criteria; a course with a bad criterion is refused naming
// file, line, column and field before anything is written.
TEST_F(ReportCommand, CourseCriteriaGradeTheTrainees) {
  {
    test::StudyDbWriter a(dir_ / "station-a.db", "station-a");
    a.trial("P1", "diagnosis", "diagnosis", 1, "2026-11-20T11:00:00Z", "2026-11-20T11:02:00Z",
            {{"lesions", "", 3, "count"},
             {"detected", "", 3, "count"},
             {"missed", "", 0, "count"},
             {"false_marks", "", 0, "count"},
             {"detection_rate", "", 1.0, "fraction"},
             {"time_to_detection", "severe", 20, "s"},
             {"time_to_detection", "severe", 25, "s"},
             {"time_to_detection", "mild", 30, "s"}});
    a.trial("P2", "diagnosis", "diagnosis", 1, "2026-11-20T12:00:00Z", "2026-11-20T12:02:00Z",
            {{"lesions", "", 3, "count"},
             {"detected", "", 1, "count"},
             {"missed", "", 2, "count"},
             {"false_marks", "", 2, "count"},
             {"detection_rate", "", 1.0 / 3.0, "fraction"},
             {"time_to_detection", "severe", 80, "s"}});
  }
  const std::string hash =
      "pbkdf2-sha256$600000$ba9f44571da1cd87db4514d1c8529d2c$"
      "507309be11afaf095e2d9b42fbb6b0639f9e4c686035c1eb08d477ec3a119722";
  const std::string head =
      "course: Class\nstudy: diagnosis\nrecords: records\nstation: s1\ninstructor: " + hash + "\ncriteria:\n";
  std::ofstream(dir_ / "course.yaml") << head << "  detection_rate: 1.0\n  time_per_lesion: 30\n";
  const fs::path out = dir_ / "report";
  test::CommandResult r =
      test::run_cariesim("report '" + (dir_ / "station-a.db").string() + "' --course '" +
                         (dir_ / "course.yaml").string() + "' --out '" + out.string() + "' --no-figures");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto passed = test::parse_rfc4180(read_text(out / "passed.csv"));
  ASSERT_EQ(passed.size(), 3U);
  EXPECT_EQ(passed[1], (std::vector<std::string>{"P1", "1", "3", "3", "pass", ""}));
  EXPECT_EQ(passed[2],
            (std::vector<std::string>{"P2", "1", "1", "3", "fail", "detection_rate, time_per_lesion"}));
  EXPECT_NE(read_text(out / "report.html").find("<h3>Who passed</h3>"), std::string::npos);

  std::ofstream(dir_ / "bad.yaml") << head << "  detection_rate: 2\n";
  const fs::path bad_out = dir_ / "bad-report";
  r = test::run_cariesim("report '" + (dir_ / "station-a.db").string() + "' --course '" +
                         (dir_ / "bad.yaml").string() + "' --out '" + bad_out.string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("bad.yaml:7:19: criteria.detection_rate: 2 is out of range [0, 1]"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(bad_out));
}

// A database that is not a study database: exit 2, the file named, no report folder written, and an
// earlier report left as it was.
TEST_F(ReportCommand, BadDatabaseNamesTheFileAndWritesNothing) {
  make_stations();
  const fs::path bad = dir_ / "notes.db";
  std::ofstream(bad) << "not a database at all, just some notes\n";
  const fs::path out = dir_ / "report";
  test::CommandResult r =
      test::run_cariesim("report " + dbs() + " '" + bad.string() + "' --out '" + out.string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("error: " + bad.string() + ": not a study database"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));

  ASSERT_EQ(test::run_cariesim("report " + dbs() + " --out '" + out.string() + "' --no-figures").status,
            0);
  const std::string earlier = read_text(out / "report.html");
  r = test::run_cariesim("report '" + bad.string() + "' --out '" + out.string() + "'");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(read_text(out / "report.html"), earlier);

  r = test::run_cariesim("report --out '" + out.string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("DB"), std::string::npos) << r.err;
}

// The example's station databases are the ones `cariesim study run` writes: another participant's
// trials append to them (the example wrote application 'cariesim', and appending said "no
// schema_version row").
TEST_F(ReportCommand, TheExampleStationsTakeMoreTrials) {
  if (!test::python3_imports("sqlite3"))
    GTEST_SKIP() << "/usr/bin/python3 is missing";
  const std::string script = std::string(CARIESIM_SOURCE_DIR) + "/examples/make_example_study.py";
  const test::CommandOutput made = test::run_command({"/usr/bin/python3", script, (dir_ / "class").string()});
  ASSERT_EQ(made.status, 0) << made.how << "\n" << made.err;
  const std::string examples = std::string(CARIESIM_SOURCE_DIR) + "/studies/examples/";
  const fs::path station = dir_ / "class" / "station-a.db";
  const test::CommandResult r = test::run_cariesim(
      "study run '" + examples + "boundary-small.yaml' --participant D6 --device 'scripted:" + examples +
          "slide-cube1.csv' --answers '" + examples + "boundary-answers.yaml' --out '" + station.string() +
          "' --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const test::CommandResult report = test::run_cariesim(
      "report '" + station.string() + "' --out '" + (dir_ / "report").string() + "' --no-figures");
  ASSERT_EQ(report.status, 0) << report.err;
  EXPECT_NE(read_text(dir_ / "report" / "boundary.csv").find("D6,"), std::string::npos);
}

// `cariesim report` run by a user who cannot write where the station databases lie (a read-only
// medium: their folder is not writable; as root, the command runs as nobody): WAL-mode databases
// were "not a study database (unable to open database file)". Now they are read as they are, one
// of them with its -wal beside it (a copy taken while the station ran), and nothing is made there.
TEST_F(ReportCommand, ReadsStationsOnAReadOnlyMedium) {
  const fs::path medium = dir_ / "medium";
  fs::create_directories(medium);
  {
    test::StudyDbWriter a(medium / "station-a.db", "station-a");
    a.db().exec("PRAGMA journal_mode=WAL", "WAL");
    a.trial("P1", "tuning", "tuning", 1, "2026-11-20T09:00:00Z", "2026-11-20T09:05:00Z",
            {{"mu_s", "mild", 0.1, ""}, {"mu_s", "severe", 0.5, ""}});
  }
  {
    // station-b as copied while its station wrote: the .db and its -wal, no -shm.
    test::StudyDbWriter b(dir_ / "live.db", "station-b");
    b.db().exec("PRAGMA journal_mode=WAL; PRAGMA wal_autocheckpoint=0", "WAL");
    b.trial("P2", "tuning", "tuning", 1, "2026-11-21T09:00:00Z", "2026-11-21T09:05:00Z",
            {{"mu_s", "mild", 0.3, ""}, {"mu_s", "severe", 0.8, ""}});
    fs::copy_file(dir_ / "live.db", medium / "station-b.db");
    fs::copy_file(dir_ / "live.db-wal", medium / "station-b.db-wal");
  }
  const auto listing = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(medium)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  const std::vector<std::string> before = listing();
  fs::permissions(medium, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                              fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
  fs::permissions(dir_, fs::perms::all);
  const fs::path out = dir_ / "report";
  const fs::path err = dir_ / "stderr.txt";

  // The command, as a user who cannot write into the medium.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (::geteuid() == 0 && (::setgroups(0, nullptr) != 0 || ::setgid(65534) != 0 || ::setuid(65534) != 0))
      ::_exit(77);
    if (::access(medium.c_str(), W_OK) == 0) ::_exit(78);  // the medium is writable after all
    const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
    if (fd >= 0) ::dup2(fd, 2);
    const std::string a = (medium / "station-a.db").string();
    const std::string b = (medium / "station-b.db").string();
    const std::string o = out.string();
    const char* exe = CARIESIM_EXE;
    char* const argv[] = {const_cast<char*>(exe),
                          const_cast<char*>("report"),
                          const_cast<char*>(a.c_str()),
                          const_cast<char*>(b.c_str()),
                          const_cast<char*>("--out"),
                          const_cast<char*>(o.c_str()),
                          const_cast<char*>("--no-figures"),
                          nullptr};
    ::execv(exe, argv);
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  fs::permissions(medium, fs::perms::owner_all, fs::perm_options::add);
  ASSERT_TRUE(WIFEXITED(status));
  if (WEXITSTATUS(status) == 77) GTEST_SKIP() << "cannot run the command as another user";
  if (WEXITSTATUS(status) == 78) GTEST_SKIP() << "no way to make a folder unwritable here";
  ASSERT_EQ(WEXITSTATUS(status), 0) << read_text(err);
  EXPECT_NE(read_text(err).find("2 database(s), 2 finished trial(s)"), std::string::npos) << read_text(err);
  const std::string table = read_text(out / "table1_roughness.csv");
  EXPECT_NE(table.find("P1,"), std::string::npos) << table;
  EXPECT_NE(table.find("P2,"), std::string::npos) << "the row in station-b's -wal is read: " << table;
  EXPECT_EQ(listing(), before) << "no -shm or -wal made beside the inputs";
}

}  // namespace
}  // namespace cariesim
