#pragma once
// The study database (docs/training.md): what `cariesim study run` and the viewer's trainee mode write,
// one row per trial with its participant, study, seed, answers and scores, and what `cariesim report`
// merges across stations. The motion of each trial is an ordinary session recording (record module)
// that the trial row names; the scores are kept in long form so a report needs no study-specific code.
#include <string_view>
#include <vector>

#include "cariesim/io/sqlite.hpp"

namespace cariesim::training {

/// schema_version.version of a study database this cariesim writes; readers refuse newer versions
/// by name. Version 1 (before the study text was stored) is still read, and appended to after adding
/// the version 2 tables (its earlier trials then cannot be rebuilt: rebuild_trial says so).
inline constexpr int kStudySchemaVersion = 2;
/// The oldest version read.
inline constexpr int kStudySchemaOldestVersion = 1;
/// PRAGMA application_id of a study database ("CRST"), beside the recordings' "CRSM".
inline constexpr int kStudyApplicationId = 0x43525354;
/// schema_version.application of a study database (a recording's is "cariesim").
inline constexpr std::string_view kStudyApplication = "cariesim-study";

/// Tables of a study database, created in one script on a new file.
///   trials: one row per trial; `ended_at` stays NULL for a trial that did not finish (a crash or
///           an abandoned case), `recording` is the trial's session recording, relative to the study
///           database's folder; `answers` and `scores` are JSON objects (docs/training.md).
///   scores: the same scores in long form: `name` from kScore*, `level` "mild"/"severe", a shape
///           name, or "" when the score has no level; `unit` "", "N/mm", "s", "N", "count",
///           "fraction".
///   studies: (version 2) the text of each study file a trial ran, once per text: `hash` its 16 hex
///           digits (Study::source_hash), `origin` the file or "builtin:NAME" it was read from.
///   trial_sources: (version 2) what rebuilds a trial besides its seed: its study's row, the
///           `--set` overrides (JSON array of {"key", "value"}), and the scene hash of its recording
///           (16 hex digits, NULL until the trial ends; docs/training.md, "rebuilding a trial").
inline constexpr std::string_view kStudySourcesSql =
    "CREATE TABLE studies (id INTEGER PRIMARY KEY, name TEXT NOT NULL, origin TEXT NOT NULL,"
    " hash TEXT NOT NULL, yaml TEXT NOT NULL);"
    "CREATE TABLE trial_sources (trial_id INTEGER PRIMARY KEY REFERENCES trials(id),"
    " study_id INTEGER NOT NULL REFERENCES studies(id), overrides TEXT NOT NULL, scene_hash TEXT);";
inline constexpr std::string_view kStudySchemaSql =
    "CREATE TABLE schema_version (version INTEGER NOT NULL, application TEXT NOT NULL);"
    "CREATE TABLE trials (id INTEGER PRIMARY KEY, station TEXT NOT NULL, participant TEXT NOT NULL,"
    " study TEXT NOT NULL, kind TEXT NOT NULL, trial INTEGER NOT NULL, seed INTEGER NOT NULL,"
    " started_at TEXT NOT NULL, ended_at TEXT, recording TEXT, answers TEXT NOT NULL,"
    " scores TEXT NOT NULL);"
    "CREATE TABLE scores (trial_id INTEGER NOT NULL REFERENCES trials(id), name TEXT NOT NULL,"
    " level TEXT NOT NULL, value REAL NOT NULL, unit TEXT NOT NULL);"
    "CREATE INDEX scores_by_trial ON scores (trial_id);"
    "CREATE TABLE studies (id INTEGER PRIMARY KEY, name TEXT NOT NULL, origin TEXT NOT NULL,"
    " hash TEXT NOT NULL, yaml TEXT NOT NULL);"
    "CREATE TABLE trial_sources (trial_id INTEGER PRIMARY KEY REFERENCES trials(id),"
    " study_id INTEGER NOT NULL REFERENCES studies(id), overrides TEXT NOT NULL, scene_hash TEXT);";

/// trials.kind
inline constexpr std::string_view kKindTuning = "tuning";
inline constexpr std::string_view kKindBoundary = "boundary-shapes";
inline constexpr std::string_view kKindDiagnosis = "diagnosis";

// scores.name. Tuning (Tables 1-2), per level mild/severe:
inline constexpr std::string_view kScoreMuS = "mu_s";  // static friction coefficient, unit ""
inline constexpr std::string_view kScoreMuD = "mu_d";  // dynamic friction coefficient, unit ""
inline constexpr std::string_view kScoreKc = "k_c";    // N/mm
inline constexpr std::string_view kScoreKe = "k_e";    // N/mm
// Boundary shapes (§4.2.2): one point when all three shapes are named right (level ""), and each
// shape's answer (level = the hidden shape's name), both 0 or 1, unit "".
inline constexpr std::string_view kScoreBoundaryPoint = "boundary_point";
inline constexpr std::string_view kScoreShapeCorrect = "shape_correct";
// Diagnosis (§5.3), level "" unless noted:
inline constexpr std::string_view kScoreLesions = "lesions";                  // count
inline constexpr std::string_view kScoreDetected = "detected";                // count
inline constexpr std::string_view kScoreMissed = "missed";                    // count
inline constexpr std::string_view kScoreFalseMarks = "false_marks";           // count
inline constexpr std::string_view kScoreDetectionRate = "detection_rate";     // fraction
inline constexpr std::string_view kScoreSeverityAccuracy = "severity_accuracy";  // fraction
inline constexpr std::string_view kScoreTimeToDetection = "time_to_detection";  // s, per lesion, level = severity
inline constexpr std::string_view kScoreCaseTime = "case_time";               // s
inline constexpr std::string_view kScoreSoftTissueTime = "soft_tissue_time";  // s
inline constexpr std::string_view kScoreSoftTissuePeak = "soft_tissue_peak_force";  // N
inline constexpr std::string_view kScoreEnamelExcessTime = "enamel_excess_force_time";  // s
inline constexpr std::string_view kScoreEnamelPeak = "enamel_peak_force";     // N
inline constexpr std::string_view kScoreBlockedInsertions = "blocked_insertions";  // count

/// The shapes a boundary study hides (a shape_correct score's level is one of them).
inline constexpr std::string_view kBoundaryShapes[] = {"square", "triangle", "circle"};

/// What a stored score may hold, as the study kinds write it: its unit, its levels and its range.
/// The report refuses any other unit, level or value of a known score, naming the row.
struct ScoreRule {
  std::string_view name;
  std::string_view unit;
  std::vector<std::string_view> levels;  ///< "" for a score without a level
  double lo = 0.0, hi = 0.0;             ///< in `unit`
  bool integral = false;                 ///< a count or a 0/1 answer
};

/// The rule of score `name`; null for a name this cariesim does not write (a later one may).
const ScoreRule* find_score_rule(std::string_view name);

/// What a study database holds, for io::open_input and io::open_for_append: the application id,
/// the version row (version kStudySchemaVersion; when `appending`, also application kStudyApplication)
/// and exactly the tables and index of kStudySchemaSql with their columns. A study database from
/// another station is an input from elsewhere: nothing else in it is accepted (docs/reports.md).
io::Schema study_schema(bool appending);

/// schema_version.version of an open study database (checked by study_schema's identify).
int study_schema_version(io::Database& db);

}  // namespace cariesim::training
