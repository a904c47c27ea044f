#pragma once
// Study databases for the report tests: a real SQLite file with the schema of
// src/training/study_schema.hpp, filled row by row as a station's study runner would.
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/training/report.hpp"
#include "cariesim/io/sqlite.hpp"
#include "training/study_schema.hpp"

namespace cariesim::test {

class StudyDbWriter {
 public:
  /// Creates `file` with the study schema, the study application id and schema version `version`.
  StudyDbWriter(const std::filesystem::path& file, std::string station,
                int version = training::kStudySchemaVersion,
                int application_id = training::kStudyApplicationId)
      : db_(file, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE), station_(std::move(station)) {
    db_.exec(std::string(training::kStudySchemaSql), "create the study schema");
    db_.exec("PRAGMA application_id=" + std::to_string(application_id), "set the application id");
    db_.exec("INSERT INTO schema_version (version, application) VALUES (" + std::to_string(version) +
                 ", 'cariesim')",
             "write the schema version");
  }

  /// Adds a trial and its scores (and its answers JSON, trials.answers); returns its id.
  std::int64_t trial(const std::string& participant, const std::string& study, const std::string& kind,
                     std::int64_t number, const std::string& started_at,
                     const std::optional<std::string>& ended_at,
                     const std::vector<training::TrialScore>& scores, std::int64_t seed = 42,
                     const std::string& answers = "{}") {
    io::Statement insert(
        db_,
        "INSERT INTO trials (station, participant, study, kind, trial, seed, started_at,"
        " ended_at, recording, answers, scores) VALUES (?, ?, ?, ?, ?, ?, ?, ?, NULL, ?, '{}')");
    insert.bind(0, station_);
    insert.bind(1, participant);
    insert.bind(2, study);
    insert.bind(3, kind);
    insert.bind(4, number);
    insert.bind(5, seed);
    insert.bind(6, started_at);
    if (ended_at) insert.bind(7, *ended_at);  // unbound stays NULL
    insert.bind(8, answers);
    if (insert.step() != SQLITE_DONE) db_.fail("insert a trial");
    const std::int64_t id = sqlite3_last_insert_rowid(db_.get());
    io::Statement score(db_,
                            "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (?, ?, ?, ?, ?)");
    for (const training::TrialScore& s : scores) {
      score.reset();
      score.bind(0, id);
      score.bind(1, s.name);
      score.bind(2, s.level);
      score.bind(3, s.value);
      score.bind(4, s.unit);
      if (score.step() != SQLITE_DONE) db_.fail("insert a score");
    }
    return id;
  }

  io::Database& db() { return db_; }

 private:
  io::Database db_;
  std::string station_;
};

}  // namespace cariesim::test
