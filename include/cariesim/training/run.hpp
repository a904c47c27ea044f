#pragma once
/// Running a study for one participant (docs/training.md): the trial sequence, the answers, and the
/// study database (src/training/study_schema.hpp) with one row per trial. The motion of a trial is an
/// ordinary session recording (servo/session.hpp with SessionOptions::record); the scores are computed
/// from that recording and the answers when the trial ends.
///
///   RunOptions options;
///   options.participant = "P01";
///   options.database = "class.db";  // created with the schema, or appended to
///   StudyRun run(load_study("boundary-shapes"), options);
///   while (!run.finished()) {
///     const TrialSetup& setup = run.begin_trial();   // the row is written, ended_at NULL
///     ... build setup.scene(), run a Session recording to run.recording_path() ...
///     run.name_shape(0, "circle"); run.name_shape(1, "square"); run.name_shape(2, "triangle");
///     const TrialResult result = run.end_trial(run.recording_path());  // scores + row, one transaction
///   }
///
/// Crash safety: begin_trial() commits a row whose ended_at is NULL before anything runs; end_trial()
/// writes answers, scores and ended_at in one transaction. A run killed mid-trial leaves the earlier
/// trials whole and that trial with ended_at NULL.
///
/// Threads: one owner thread calls every member (the viewer's UI thread, the command's main thread).

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/training/course.hpp"
#include "cariesim/training/study.hpp"

namespace cariesim::training {

/// Who runs a study, where, and into which database.
struct RunOptions {
  std::string participant;         ///< required, e.g. "P01" (letters, digits, '-', '_', '.')
  std::string station;             ///< this machine's name in trials.station; empty: the host name
  std::filesystem::path database;  ///< the study database, created when missing
  /// The study seed; unset: the study file's seed, else one drawn from std::random_device.
  std::optional<uint64_t> seed;
  /// Every participant gets the same trials, those of the study seed itself (a course's `exam_seed`,
  /// docs/instructors.md). Off: the trials of participant_seed(seed, participant), so two
  /// participants never share a case, even with one fixed seed.
  bool same_cases = false;
  std::optional<int> trials;  ///< overrides the study's trial count
  /// Folder of the trials' recordings; relative paths are taken from the database's folder. Empty:
  /// "DB-recordings" beside the database (DB its file name without extension), so two databases in
  /// one folder never share a recording name.
  std::filesystem::path recordings;
  /// s a write to the database waits for another program's lock (retrying with a growing backoff)
  /// before a trial's answers and scores go to a pending file beside it (pending_folder()).
  double lock_wait = 10.0;
  /// Files this run creates are the owner's only: a new database 0600 (SQLite gives its -wal and -shm
  /// files the same), a new recordings folder 0700. Existing files and folders keep their modes.
  bool private_files = true;
  /// Trainee mode (the viewer's course): nothing on disk names the running trial's case. Its row is
  /// written at begin_trial with the seed kSeedNotWritten, and the seed at end_trial or
  /// abandon_trial; a crash leaves kSeedNotWritten. (The trial's recording is held in memory by its
  /// Session, RecorderOptions::hold_until_stop.)
  bool hide_case_while_running = false;
  /// Parameter overrides placed into every trial's scene (`--set`, docs/scene-format.md,
  /// "Overrides"); the trial's scene text holds them, so its recording and scores see that scene.
  std::vector<SceneOverride> overrides;
};

/// What a course says about a run's cases (docs/instructors.md): with an `exam_seed`, that seed and
/// RunOptions::same_cases (every trainee the same cases); without, nothing (each trainee their own).
void apply_course_seed(const Course& course, RunOptions& options);

/// trials.seed of a trial that runs in trainee mode (RunOptions::hide_case_while_running) and has
/// not ended yet, or was cut short by a crash; seeds themselves are in [0, 2^63).
inline constexpr int64_t kSeedNotWritten = -1;

/// Creates a folder for study databases or recordings (and its missing parents); the folder itself,
/// when new, is owner-only (0700). Throws cariesim::Error naming the folder and the reason.
void create_study_folder(const std::filesystem::path& folder);

/// A diagnosis mark: the participant held the tip here and pressed the mark key or button.
struct Mark {
  Vec3 tip = Vec3::Zero();  ///< mm, world: the graphic tool's tip (tool-frame origin)
  Grade grade = Grade::Mild;
  double t = 0.0;  ///< s, servo time of the press (the recording's clock)
  /// The tool touched something when the mark was made (ServoSnapshot::out.contacts > 0): a mark
  /// made in the air detects nothing (it is a false mark), however close above a lesion.
  bool contact = true;
};

/// The participant's answers to one trial, as the run collected them (trials.answers as JSON).
struct TrialAnswers {
  /// Tuning: level -> parameter name -> confirmed value (in the parameter's unit), and the servo
  /// time (s) of each confirmation.
  std::map<std::string, std::map<std::string, double>> tuned;
  std::map<std::string, double> confirmed_at;
  /// Boundary: the shape named for each cube (empty when not named).
  std::vector<std::string> shapes;
  /// Diagnosis: the marks in the order made, and the servo time (s) the case was ended (unset: the
  /// trial ended without it, e.g. at the time limit).
  std::vector<Mark> marks;
  std::optional<double> ended_at;
};

/// One score (a row of the study database's scores table).
struct Score {
  std::string name;    ///< kScore* of study_schema.hpp
  std::string level;   ///< "mild"/"severe", a shape name, or ""
  double value = 0.0;  ///< in unit
  std::string unit;    ///< "", "N/mm", "s", "N", "count", "fraction"
};

/// What ending a trial wrote.
struct TrialResult {
  int64_t row = 0;  ///< trials.id
  int index = 0;    ///< 0-based trial number
  uint64_t seed = 0;
  std::filesystem::path recording;  ///< as stored: relative to the database's folder when inside it
  TrialAnswers answers;
  std::vector<Score> scores;
  std::string answers_json;  ///< trials.answers
  std::string scores_json;   ///< trials.scores
  /// Empty when the results are in the database. Else the database stayed locked by another program
  /// for RunOptions::lock_wait: the pending file that holds them (in pending_folder()), merged into
  /// the database when it is next opened or a trial next begins.
  std::filesystem::path pending;
};

/// The folder beside a study database where trial results wait while the database is locked:
/// DATABASE-pending (e.g. class.db-pending/trial-7.json for trials.id 7).
std::filesystem::path pending_folder(const std::filesystem::path& database);

class StudyRun {
 public:
  /// Opens (or creates, with the schema) the study database and draws the study seed. An existing
  /// database is checked as any input (io::open_for_append: exactly the study schema, so no trigger
  /// or view of its own), then the pending results beside it are merged. Throws cariesim::Error
  /// naming the file and the reason (not a study database, another schema version, unwritable,
  /// locked by another program) or the bad option (empty or malformed participant, trial count < 1).
  StudyRun(Study study, RunOptions options);
  ~StudyRun();
  StudyRun(const StudyRun&) = delete;
  StudyRun& operator=(const StudyRun&) = delete;

  [[nodiscard]] const Study& study() const { return study_; }
  [[nodiscard]] const RunOptions& options() const { return options_; }
  /// The study seed in use (recorded through every trial's seed).
  [[nodiscard]] uint64_t seed() const { return seed_; }
  /// The seed of trial `index` (0-based) in this run (trials.seed): trial_seed(participant_seed(seed(),
  /// participant), index), or trial_seed(seed(), index) with RunOptions::same_cases.
  [[nodiscard]] uint64_t seed_of_trial(int index) const;
  /// Trials in this run.
  [[nodiscard]] int trial_count() const { return trial_count_; }
  /// 0-based index of the current trial (the one begun, or the next to begin); trial_count() when done.
  [[nodiscard]] int current_trial() const { return current_; }
  /// True when every trial has ended.
  [[nodiscard]] bool finished() const { return current_ >= trial_count_; }
  /// True between begin_trial() and end_trial().
  [[nodiscard]] bool in_trial() const { return in_trial_; }

  /// Makes the current trial (make_trial with its seed) and commits its row (ended_at NULL), after
  /// merging pending results. A lock held by another program is waited for (RunOptions::lock_wait).
  /// Throws cariesim::Error when finished, already in a trial, or the database cannot be written.
  const TrialSetup& begin_trial();
  /// The setup trial `index` gets when it begins (make_trial from its seed, with the run's
  /// overrides), made without touching the database: e.g. to build the next trial's scene while the
  /// current one runs. Throws cariesim::Error as make_trial does.
  [[nodiscard]] TrialSetup trial_setup(int index) const;
  /// The current trial's setup (valid after begin_trial()).
  [[nodiscard]] const TrialSetup& setup() const { return setup_; }
  /// Where the current trial's recording should go (absolute; its folder is created by
  /// begin_trial()): RECORDINGS/STUDY-PARTICIPANT-ROW.db (ROW = trials.id).
  [[nodiscard]] const std::filesystem::path& recording_path() const { return recording_path_; }

  /// Tuning: the level being tuned now (setup().levels in order), or nullopt when all are confirmed.
  [[nodiscard]] std::optional<Grade> current_level() const;
  /// Tuning: confirms the values of the current level (every setup().parameters name, each within
  /// its slider range) at servo time t (s) and moves to the next level. Throws cariesim::Error
  /// naming the parameter when a value is missing, unknown, not finite or out of range, or when no
  /// level is left.
  void confirm_tuning(const std::map<std::string, double>& values, double t);
  /// Boundary: names the shape of cube `cube` (0-based, setup().cubes order); a later call replaces
  /// it. Throws cariesim::Error for a cube out of range or a name not in setup().shape_choices.
  void name_shape(int cube, const std::string& shape);
  /// Diagnosis: a mark at the tip (mm, world) graded mild/severe at servo time t (s); `contact`:
  /// the tool touched something then (Mark::contact). Throws cariesim::Error for a non-finite tip
  /// or time, or after end_case().
  void mark(const Vec3& tip, Grade grade, double t, bool contact = true);
  /// Diagnosis: the participant ends the case at servo time t (s).
  void end_case(double t);
  /// The answers so far.
  [[nodiscard]] const TrialAnswers& answers() const { return answers_; }

  /// Ends the current trial: loads the recording (record/recorder.hpp load_recording; an empty
  /// path: no recording, the motion scores are then absent), computes the scores (docs/training.md),
  /// and writes answers, scores, the recording's path and ended_at in one transaction. A diagnosis
  /// trial judges the marks against `model`'s lesions (the model built from setup().scene(), whose
  /// lesions are snapped onto the teeth); without one the scene is built here (a tree-cache hit
  /// after the trial ran). When another program holds the database locked for longer than
  /// RunOptions::lock_wait, the results are never dropped: they go to a pending file
  /// (TrialResult::pending) merged later. Throws cariesim::Error naming what failed (no trial begun,
  /// an unreadable recording, incomplete answers: a tuning level not confirmed); the row then stays
  /// with ended_at NULL and the trial stays current.
  TrialResult end_trial(const std::filesystem::path& recording, const Model* model = nullptr);
  /// Leaves the current trial unfinished (its row keeps ended_at NULL) and moves to the next. A
  /// non-empty `reason` (why it could not start or be saved; it may name the case's lesions) goes into
  /// the row's answers as {"error": reason}, never to the screen; a hidden seed is written now.
  /// Database failures here are not thrown: the trial is abandoned whatever happens.
  void abandon_trial(const std::string& reason = {});

 private:
  struct Db;
  Study study_;
  RunOptions options_;
  std::unique_ptr<Db> db_;
  uint64_t seed_ = 0;
  int trial_count_ = 0;
  int current_ = 0;
  bool in_trial_ = false;
  int64_t row_ = 0;
  std::string started_at_;  // the current trial's trials.started_at
  TrialSetup setup_;
  std::filesystem::path recording_path_;
  TrialAnswers answers_;
  std::size_t level_ = 0;  // next tuning level to confirm
};

}  // namespace cariesim::training
