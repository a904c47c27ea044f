// Appending to a study database (`study run`, the viewer's trainee mode): a database holding anything
// but the study schema (a planted trigger) is refused before anything is written, and a database
// another program holds locked never loses a trial's answers and scores.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/training/report.hpp"
#include "cariesim/training/run.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

Study boundary_small() { return load_study((test::examples() / "boundary-small.yaml").string()); }

RunOptions options(const fs::path& db, const std::string& participant) {
  RunOptions o;
  o.participant = participant;
  o.station = "station-1";
  o.database = db;
  return o;
}

// One boundary trial named all right (or all wrong: each cube the next cube's shape).
TrialResult boundary_trial(StudyRun& run, bool right) {
  const TrialSetup& t = run.begin_trial();
  const std::size_t n = t.truth.shapes.size();
  for (std::size_t c = 0; c < n; ++c)
    run.name_shape(static_cast<int>(c), t.truth.shapes[right ? c : (c + 1) % n]);
  return run.end_trial("");
}

void exec(sqlite3* db, const char* sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &error);
  const std::string message = error != nullptr ? error : "";
  sqlite3_free(error);
  ASSERT_EQ(rc, SQLITE_OK) << sql << ": " << message;
}

// Item: a trigger planted in a station database rewrote later scores (a trial whose three shapes were
// all named wrong was stored as boundary_point 1, 10/10 in the report). The run refuses the database,
// naming the trigger, and writes nothing; the report refuses it too.
TEST(StudyAppend, APlantedTriggerIsRefusedBeforeAnythingIsWritten) {
  const fs::path db = test::scratch() / "class.db";
  {
    StudyRun run(boundary_small(), options(db, "P01"));
    boundary_trial(run, true);
  }
  sqlite3* handle = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &handle), SQLITE_OK);
  exec(handle,
       "CREATE TRIGGER full_marks AFTER INSERT ON scores WHEN new.name = 'boundary_point' "
       "BEGIN UPDATE scores SET value = 1 WHERE rowid = new.rowid; END;");
  sqlite3_close(handle);

  std::string error = "<no error>";
  try {
    StudyRun run(boundary_small(), options(db, "P02"));
    boundary_trial(run, false);
  } catch (const Error& e) {
    error = e.what();
  }
  EXPECT_THAT(error, HasSubstr(db.string() + ": refused: it holds a trigger 'full_marks' on 'scores'"));
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM trials WHERE participant = 'P02'")[0][0], "0");
  EXPECT_EQ(test::query(db,
                        "SELECT count(*) FROM scores JOIN trials ON trials.id = scores.trial_id WHERE "
                        "participant = 'P02' AND name = 'boundary_point' AND value = 1")[0][0],
            "0")
      << "the all-wrong trial was not stored as a point";
  try {
    merge_study_databases({db});
    ADD_FAILURE() << "the report read a database with a trigger";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("it holds a trigger 'full_marks'"));
  }
}

// Item: a station database locked by another program for longer than the busy timeout lost the
// trial's answers and scores (they were only in memory). Now they go to a pending file beside the
// database and are merged on the next open.
TEST(StudyAppend, ResultsOfALockedDatabaseWaitInAPendingFileAndAreMerged) {
  const fs::path db = test::scratch() / "class.db";
  RunOptions o = options(db, "P01");
  o.lock_wait = 0.5;  // s
  TrialResult result;
  {
    StudyRun run(boundary_small(), o);
    const TrialSetup& t = run.begin_trial();
    for (std::size_t c = 0; c < t.truth.shapes.size(); ++c)
      run.name_shape(static_cast<int>(c), t.truth.shapes[c]);
    // Another program holds the write lock while the trial ends.
    sqlite3* other = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &other), SQLITE_OK);
    exec(other, "BEGIN IMMEDIATE");
    const auto start = std::chrono::steady_clock::now();
    EXPECT_NO_THROW(result = run.end_trial(""));
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
    exec(other, "COMMIT");
    sqlite3_close(other);
  }
  ASSERT_FALSE(result.pending.empty());
  EXPECT_EQ(result.pending, pending_folder(db) / ("trial-" + std::to_string(result.row) + ".json"));
  EXPECT_TRUE(fs::exists(result.pending));
  const std::string row = std::to_string(result.row);
  EXPECT_EQ(test::query(db, "SELECT ended_at FROM trials WHERE id = " + row)[0][0], "NULL");
  // The report says they wait there.
  const Report waiting = build_report(merge_study_databases({db}));
  ASSERT_EQ(waiting.merged.inputs.size(), 1u);
  EXPECT_EQ(waiting.merged.inputs[0].pending, 1u);
  EXPECT_TRUE(std::any_of(waiting.warnings.begin(), waiting.warnings.end(), [](const std::string& w) {
    return w.find("1 trial result(s) wait in") != std::string::npos;
  }));

  // The next open (another participant at the same station) merges them.
  { StudyRun next(boundary_small(), options(db, "P02")); }
  EXPECT_NE(test::query(db, "SELECT ended_at FROM trials WHERE id = " + row)[0][0], "NULL");
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM scores WHERE trial_id = " + row)[0][0],
            std::to_string(result.scores.size()));
  EXPECT_EQ(
      test::query(db, "SELECT value FROM scores WHERE name = 'boundary_point' AND trial_id = " + row)[0][0],
      "1.0");
  EXPECT_EQ(test::query(db, "SELECT answers FROM trials WHERE id = " + row)[0][0], result.answers_json);
  EXPECT_FALSE(fs::exists(result.pending)) << "merged files are removed";
  EXPECT_EQ(merge_study_databases({db}).finished.size(), 1u);
}

// A lock released while the run retries: the results go straight into the database.
TEST(StudyAppend, ALockReleasedWhileRetryingIsWaitedFor) {
  const fs::path db = test::scratch() / "class.db";
  RunOptions o = options(db, "P01");
  o.lock_wait = 10.0;  // s
  StudyRun run(boundary_small(), o);
  const TrialSetup& t = run.begin_trial();
  for (std::size_t c = 0; c < t.truth.shapes.size(); ++c)
    run.name_shape(static_cast<int>(c), t.truth.shapes[c]);
  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &other), SQLITE_OK);
  exec(other, "BEGIN IMMEDIATE");
  std::thread release([other] {
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    sqlite3_exec(other, "COMMIT", nullptr, nullptr, nullptr);
  });
  const TrialResult result = run.end_trial("");
  release.join();
  sqlite3_close(other);
  EXPECT_TRUE(result.pending.empty());
  EXPECT_NE(test::query(db, "SELECT ended_at FROM trials WHERE id = " + std::to_string(result.row))[0][0],
            "NULL");
}

}  // namespace
}  // namespace cariesim::training
