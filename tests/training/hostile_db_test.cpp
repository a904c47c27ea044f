// Station databases from elsewhere, as `cariesim report` reads them: crafted files (each built here by
// a small SQL generator) run none of their own SQL, cannot make the report spin, fill the disk or use
// memory out of proportion, hold only values of the declared types and ranges, are read without a
// file made beside them, and a locked one is named as locked.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/training/report.hpp"
#include "support/deadline.hpp"
#include "support/raw_sql.hpp"
#include "training/study_db_support.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

// s: far more than a refusal takes; a reader that runs the crafted SQL never ends.
constexpr double kDeadline = 10.0;

using cariesim::test::run_sql;

std::string read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string merge_error(const fs::path& file) {
  try {
    merge_study_databases({file});
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

// A station with one finished boundary trial, as a station writes it.
fs::path station(const fs::path& file) {
  cariesim::test::StudyDbWriter w(file, "station-a");
  w.trial("P1", "boundary-shapes", "boundary-shapes", 1, "2026-11-20T09:00:00Z", "2026-11-20T09:01:00Z",
          {{"boundary_point", "", 1.0, ""},
           {"shape_correct", "square", 1.0, ""},
           {"shape_correct", "triangle", 1.0, ""},
           {"shape_correct", "circle", 1.0, ""}});
  return file;
}

// Item: a 20 KB station database whose `trials` is a recursive view made `report` spin forever (and
// one ordered by id filled the disk with temporary files); both are refused at once, naming the view.
TEST(HostileStudyDb, ARecursiveViewIsRefusedAtOnce) {
  const fs::path dir = test::scratch();
  const struct {
    const char* name;
    const char* view;
  } cases[] = {
      {"spin.db",
       "CREATE VIEW trials AS WITH RECURSIVE r(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM r) "
       "SELECT i AS id, 's' AS station, 'P' || i AS participant, 'x' AS study, 'tuning' AS kind, 1 AS trial, "
       "1 AS seed, 't' AS started_at, 't' AS ended_at, NULL AS recording, '{}' AS answers, '{}' AS scores "
       "FROM r WHERE i < 0;"},
      {"fill.db",
       "CREATE VIEW trials AS WITH RECURSIVE r(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM r) "
       "SELECT -i AS id, hex(randomblob(512)) AS station, 'P' AS participant, 'x' AS study, 'tuning' AS "
       "kind, "
       "1 AS trial, 1 AS seed, 't' AS started_at, 't' AS ended_at, NULL AS recording, '{}' AS answers, "
       "'{}' AS scores FROM r;"},
  };
  for (const auto& c : cases) {
    const fs::path file = dir / c.name;
    { cariesim::test::StudyDbWriter w(file, "station-a"); }
    run_sql(file, std::string("DROP TABLE trials; ") + c.view);
    EXPECT_LT(fs::file_size(file), 64u * 1024u) << "a small file";
    const cariesim::test::DeadlineResult r =
        cariesim::test::run_with_deadline([&] { merge_study_databases({file}); }, kDeadline);
    EXPECT_TRUE(r.finished) << c.name << ": " << r.message;
    EXPECT_TRUE(r.threw) << c.name;
    EXPECT_THAT(r.message, HasSubstr(file.string() + ": refused: its 'trials' is a view")) << c.name;
    EXPECT_LT(r.seconds, 5.0) << c.name;
  }
}

// Item: every distinct shape_correct level became two report columns per participant (0.57 MB in,
// 2.6 GB of memory); only the shapes a boundary study hides are levels, any other is refused by row.
TEST(HostileStudyDb, UnknownLevelsAreRefusedNamingTheRow) {
  const fs::path dir = test::scratch();
  const fs::path file = station(dir / "levels.db");
  run_sql(file,
          "WITH RECURSIVE r(i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM r LIMIT 2000) "
          "INSERT INTO scores (trial_id, name, level, value, unit) SELECT 1, 'shape_correct', 'evil-' || i, "
          "1.0, '' FROM r;");
  const std::string error = merge_error(file);
  EXPECT_THAT(error,
              HasSubstr(file.string() + ": scores, row 5 (trial id 1, score 'shape_correct'), column level"));
  EXPECT_THAT(error, HasSubstr("'evil-0' is not a level of shape_correct (square, triangle, circle)"));
  // A tuning value at a level no study asks for, the same.
  const fs::path tuning = station(dir / "tuning-level.db");
  run_sql(tuning,
          "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (1, 'mu_s', 'medium', 0.3, '')");
  EXPECT_THAT(merge_error(tuning), HasSubstr("'medium' is not a level of mu_s (mild, severe)"));
}

// Item: a score stored as text or a blob became 0, negative counts passed, 1e308 emptied the cohort
// cells without a note. Each is refused naming the file, table, row and column.
TEST(HostileStudyDb, BadValuesAreRefusedNamingTheRowAndColumn) {
  const fs::path dir = test::scratch();
  const struct {
    const char* name;
    const char* sql;
    const char* expected;
  } cases[] = {
      {"text.db", "UPDATE scores SET value = 'high' WHERE rowid = 1",
       "scores, row 1 (trial id 1, score 'boundary_point'), column value: stored as TEXT, expected a REAL "
       "number"},
      {"blob.db", "UPDATE scores SET value = x'00ff' WHERE rowid = 2",
       "scores, row 2 (trial id 1, score 'shape_correct'), column value: stored as BLOB, expected a REAL "
       "number"},
      {"negative.db",
       "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (1, 'detected', '', -3.0, 'count')",
       "scores, row 5 (trial id 1, score 'detected'), column value: -3 is not a value of detected (expected "
       "a "
       "whole number in [0, 1000000] count)"},
      {"huge.db",
       "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (1, 'mu_s', 'mild', 1e308, '')",
       "scores, row 5 (trial id 1, score 'mu_s'), column value: 1e+308 is not a value of mu_s (expected a "
       "number "
       "in [0, 5])"},
      {"fraction.db", "UPDATE scores SET value = 0.5 WHERE rowid = 1",
       "column value: 0.5 is not a value of boundary_point (expected a whole number in [0, 1])"},
      {"unit.db",
       "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (1, 'k_c', 'mild', 0.4, 'N')",
       "column unit: 'N' is not the unit of k_c ('N/mm')"},
      {"trial-text.db", "UPDATE trials SET trial = 'one' WHERE id = 1",
       "trials, row 1, column trial: stored as TEXT, expected an INTEGER"},
      {"seed.db", "UPDATE trials SET seed = -5 WHERE id = 1",
       "trials, row 1, column seed: -5 is not a trial seed"},
      {"participant-blob.db", "UPDATE trials SET participant = x'5031' WHERE id = 1",
       "trials, row 1, column participant: stored as BLOB, expected TEXT"},
  };
  for (const auto& c : cases) {
    const fs::path file = station(dir / c.name);
    run_sql(file, c.sql);
    const std::string error = merge_error(file);
    EXPECT_THAT(error, HasSubstr(file.string() + ": ")) << c.name;
    EXPECT_THAT(error, HasSubstr(c.expected)) << c.name;
  }
  // The station as written reads.
  EXPECT_EQ(merge_study_databases({station(dir / "good.db")}).finished.size(), 1u);
}

// Item: reading a station database in a writable folder left X.db-shm (and X.db-wal) beside it; now
// nothing is made beside it and no byte of it changes.
TEST(HostileStudyDb, ReadingMakesNoFileBesideTheDatabase) {
  const fs::path dir = test::scratch();
  const fs::path file = station(dir / "wal.db");
  run_sql(file, "PRAGMA journal_mode=WAL;");
  ASSERT_FALSE(fs::exists(file.string() + "-wal"));
  const std::string before = read_bytes(file);
  EXPECT_EQ(merge_study_databases({file}).finished.size(), 1u);
  EXPECT_FALSE(fs::exists(file.string() + "-shm"));
  EXPECT_FALSE(fs::exists(file.string() + "-wal"));
  EXPECT_EQ(read_bytes(file), before);
}

// Item: a database another program holds locked was "not a study database (database is locked)".
TEST(HostileStudyDb, ALockedDatabaseIsNamedAsLocked) {
  const fs::path dir = test::scratch();
  const fs::path file = station(dir / "locked.db");
  int ready[2];
  int release[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(release), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The other program: a station in the middle of writing (its exclusive lock held).
    sqlite3* db = nullptr;
    char byte = sqlite3_open(file.c_str(), &db) == SQLITE_OK &&
                        sqlite3_exec(db, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr) == SQLITE_OK
                    ? 'L'
                    : 'E';
    (void)::write(ready[1], &byte, 1);
    (void)::read(release[0], &byte, 1);
    ::_exit(0);
  }
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1);
  ASSERT_EQ(byte, 'L');
  const std::string error = merge_error(file);
  (void)::write(release[1], &byte, 1);
  int status = 0;
  ::waitpid(child, &status, 0);
  for (const int fd : {ready[0], ready[1], release[0], release[1]}) ::close(fd);
  EXPECT_THAT(error, HasSubstr(file.string() + ": locked by another program"));
  EXPECT_THAT(error, Not(HasSubstr("not a study database")));
}

}  // namespace
}  // namespace cariesim::training
