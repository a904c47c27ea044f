#include "training/study_schema.hpp"

#include <sqlite3.h>

#include <array>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim::training {

static_assert(kStudySchemaVersion > 0, "a study database has a positive schema version");

namespace {

// Bounds of the stored values: the widest a study file lets a slider span (study.cpp), a count or a
// time far beyond any trial, a force far beyond any device's limit.
constexpr double kMaxFriction = 5.0;     // the widest mu slider
constexpr double kMaxStiffness = 100.0;  // N/mm, the widest k slider
constexpr double kMaxCount = 1.0e6;      // lesions, marks, presses in one trial
constexpr double kMaxSeconds = 1.0e6;    // s of servo time in one trial
constexpr double kMaxForce = 1.0e4;      // N

}  // namespace

const ScoreRule* find_score_rule(std::string_view name) {
  static const std::vector<std::string_view> kGrades = {"mild", "severe"};
  static const std::vector<std::string_view> kNone = {""};
  static const std::vector<std::string_view> kShapes(std::begin(kBoundaryShapes), std::end(kBoundaryShapes));
  static const std::array<ScoreRule, 19> kRules = {{
      {kScoreMuS, "", kGrades, 0.0, kMaxFriction, false},
      {kScoreMuD, "", kGrades, 0.0, kMaxFriction, false},
      {kScoreKc, "N/mm", kGrades, 0.0, kMaxStiffness, false},
      {kScoreKe, "N/mm", kGrades, 0.0, kMaxStiffness, false},
      {kScoreBoundaryPoint, "", kNone, 0.0, 1.0, true},
      {kScoreShapeCorrect, "", kShapes, 0.0, 1.0, true},
      {kScoreLesions, "count", kNone, 0.0, kMaxCount, true},
      {kScoreDetected, "count", kNone, 0.0, kMaxCount, true},
      {kScoreMissed, "count", kNone, 0.0, kMaxCount, true},
      {kScoreFalseMarks, "count", kNone, 0.0, kMaxCount, true},
      {kScoreDetectionRate, "fraction", kNone, 0.0, 1.0, false},
      {kScoreSeverityAccuracy, "fraction", kNone, 0.0, 1.0, false},
      {kScoreTimeToDetection, "s", kGrades, 0.0, kMaxSeconds, false},
      {kScoreCaseTime, "s", kNone, 0.0, kMaxSeconds, false},
      {kScoreSoftTissueTime, "s", kNone, 0.0, kMaxSeconds, false},
      {kScoreSoftTissuePeak, "N", kNone, 0.0, kMaxForce, false},
      {kScoreEnamelExcessTime, "s", kNone, 0.0, kMaxSeconds, false},
      {kScoreEnamelPeak, "N", kNone, 0.0, kMaxForce, false},
      {kScoreBlockedInsertions, "count", kNone, 0.0, kMaxCount, true},
  }};
  for (const ScoreRule& rule : kRules)
    if (rule.name == name) return &rule;
  return nullptr;
}

io::Schema study_schema(bool appending) {
  io::Schema schema;
  schema.what = "study database";
  schema.application_id = kStudyApplicationId;
  schema.known_applications = {{0x4352534D, "a cariesim session recording"}};
  schema.version_table = "schema_version";
  schema.identify = [appending](io::Database& db) {
    io::Statement version(db, "SELECT version, application FROM schema_version");
    const int rc = version.step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) db.fail("cannot read the schema version");
    if (rc != SQLITE_ROW) throw Error(db.file() + ": not a study database (schema_version has no row)");
    if (version.type(0) != SQLITE_INTEGER)
      throw Error(db.file() + ": not a study database (schema_version.version is not an integer)");
    const std::int64_t v = version.integer(0);
    if (v > kStudySchemaVersion)
      throw Error(db.file() + ": study database schema version " + std::to_string(v) +
                  " is newer than this cariesim reads (" + std::to_string(kStudySchemaVersion) +
                  "); report it with a newer cariesim");
    if (v < kStudySchemaOldestVersion)
      throw Error(db.file() + ": study database schema version " + std::to_string(v) +
                  " is not supported (this cariesim reads versions " +
                  std::to_string(kStudySchemaOldestVersion) + " to " + std::to_string(kStudySchemaVersion) +
                  ")");
    // Version 2 added the study sources: a file that says 2 must hold them.
    if (v >= 2) {
      for (const char* table : {"studies", "trial_sources"}) {
        io::Statement has(db, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = ?");
        has.bind(0, std::string(table));
        if (has.step() != SQLITE_ROW) db.fail("cannot read the schema");
        if (has.integer(0) == 0)
          throw Error(db.file() + ": not a study database (schema version " + std::to_string(v) +
                      " but the table '" + table + "' is missing)");
      }
    }
    if (appending && version.text(1) != kStudyApplication)
      throw Error(db.file() + ": not a study database cariesim appends to (schema_version.application is '" +
                  version.text(1) + "', not '" + std::string(kStudyApplication) + "')");
  };
  using Type = io::SchemaObject::Type;
  schema.objects = {
      {Type::Table, "schema_version", "schema_version", {"version", "application"}},
      {Type::Table,
       "trials",
       "trials",
       {"id", "station", "participant", "study", "kind", "trial", "seed", "started_at", "ended_at",
        "recording", "answers", "scores"}},
      {Type::Table, "scores", "scores", {"trial_id", "name", "level", "value", "unit"}},
      {Type::Index, "scores_by_trial", "scores", {}},
      {Type::Table, "studies", "studies", {"id", "name", "origin", "hash", "yaml"}, true},
      {Type::Table,
       "trial_sources",
       "trial_sources",
       {"trial_id", "study_id", "overrides", "scene_hash"},
       true},
  };
  return schema;
}

int study_schema_version(io::Database& db) {
  io::Statement version(db, "SELECT version FROM schema_version");
  if (version.step() != SQLITE_ROW) db.fail("cannot read the schema version");
  return static_cast<int>(version.integer(0));
}

}  // namespace cariesim::training
