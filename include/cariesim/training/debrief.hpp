#pragma once
/// A trial rebuilt from its study database, and the debrief of a diagnosis case (docs/training.md,
/// "Debrief" and "Rebuilding a trial"): what the window shows a trainee after a case and what
/// `cariesim review DB` shows for any past trial.
///
///   const RebuiltTrial t = rebuild_trial("class.db", "P01", 2);  // P01's 2nd trial in the file
///   const Model model = build_model(t.setup.scene());
///   check_rebuilt_scene(t, model, &recording.info);              // throws on any hash mismatch
///   const Debrief d = make_debrief(t.setup, t.answers, t.scores, &recording, t.study.scoring);
///
/// The study database is an input from elsewhere: rebuild_trial reads it through io::open_input with
/// the study schema, every column of its stored type, the stored study text against its hash and the
/// stored case against the case the seed rebuilds; anything else is refused naming the file, the
/// table, the row and the column.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/training/run.hpp"
#include "cariesim/training/study.hpp"

namespace cariesim::training {

/// One diagnosis mark as the study database stores it: the mark and how it was judged.
struct JudgedMark {
  Mark mark;
  int lesion = -1;        ///< the case's lesion it detected (0-based), -1: none
  double distance = 0.0;  ///< mm, from the tip to that lesion's volume (or the nearest lesion's)
  bool first = false;     ///< the first mark on that lesion (later ones neither count nor are false)
};

/// A diagnosis trial's answers as stored (trials.answers, docs/training.md): the case, the judged
/// marks, when the case was ended.
struct DiagnosisAnswers {
  std::vector<CaseLesion> lesions;  ///< the case as the trial ran it
  std::vector<JudgedMark> marks;    ///< in the order made
  std::optional<double> ended_at;   ///< s, servo time of End case; unset: the time limit or path end
  bool placed = false;  ///< the lesions' shape and offset were stored (rows since sites are regions)
};

/// Reads a diagnosis trial's answers JSON (trials.answers or TrialResult::answers_json). `where`
/// names it in messages ("class.db: trials, row 7, column answers"). Throws cariesim::Error naming
/// the field for anything malformed, out of range or too large.
DiagnosisAnswers parse_diagnosis_answers(std::string_view json, const std::string& where);

/// A trial of a study database, rebuilt from the database alone.
struct RebuiltTrial {
  std::filesystem::path database;  ///< the file it came from
  int64_t row = 0;                 ///< trials.id
  std::string station, participant, study_name;
  int number = 0;     ///< the participant's trials in the file, from 1 (by row order)
  int run_trial = 0;  ///< trials.trial: its number within its run, from 1
  uint64_t seed = 0;  ///< trials.seed
  std::string started_at, ended_at;
  std::filesystem::path recording;  ///< absolute path of the trial's recording; empty: none stored
  Study study;                      ///< parsed from the stored text (studies.yaml)
  TrialSetup setup;                 ///< make_trial(study, run_trial - 1, seed) with the stored overrides
  /// The recorded scene's hash (trial_sources.scene_hash); unset when the trial had no recording.
  std::optional<uint64_t> scene_hash;
  DiagnosisAnswers answers;   ///< a diagnosis trial's answers (empty for other kinds)
  std::vector<Score> scores;  ///< the trial's rows of the scores table

  /// "P01, trial 2 (row 7)".
  [[nodiscard]] std::string label() const;
};

/// Rebuilds one ended trial of `database`: `participant` (empty: the only one in the file) and
/// `number`, the participant's N-th trial in the file (unset: their last ended one). The study is
/// parsed from its stored text (a scene file it names is read from where the study was; the scene
/// hash check then catches a changed one), the trial remade from its seed (make_trial, so changes to
/// how cases are drawn flow through), and the stored case compared with the rebuilt one. Throws
/// cariesim::Error naming the file, the table, the row and the column for a tampered or malformed
/// row, a trial recorded before the study text was stored (a schema version 1 database), a trial
/// that did not end, or no such participant or trial.
RebuiltTrial rebuild_trial(const std::filesystem::path& database, const std::string& participant = {},
                           std::optional<int> number = std::nullopt);

/// Checks the model built from a rebuilt trial's scene against the recorded scene: the stored
/// scene hash and, when given, the recording's own (session.scene_hash). Throws cariesim::Error
/// naming both hashes and where each came from when they differ.
void check_rebuilt_scene(const RebuiltTrial& trial, const Model& model, const SessionInfo* recording);

/// What a mark was, in the debrief.
enum class MarkVerdict : uint8_t {
  Found,  ///< the first mark on a lesion: it detected it
  Again,  ///< a later mark on a lesion already found (neither counts nor is false)
  False,  ///< on no lesion
  InAir,  ///< made with the tool touching nothing (detects nothing; a false mark)
};
/// "found", "again", "false", "in the air".
std::string_view mark_verdict_name(MarkVerdict verdict);

/// One lesion of the case, revealed.
struct DebriefLesion {
  int number = 0;  ///< 1-based, the scene's lesionN
  std::string site;
  Grade severity = Grade::Mild;
  double size = 0.0;   ///< mm
  double depth = 0.0;  ///< mm
  bool found = false;
  std::optional<Grade> graded;     ///< the grade of the mark that found it
  std::optional<double> found_at;  ///< s, servo time of that mark
  [[nodiscard]] bool grade_right() const { return graded && *graded == severity; }
};

/// One mark, judged.
struct DebriefMark {
  int number = 0;  ///< 1-based, in the order made
  double t = 0.0;  ///< s
  Grade grade = Grade::Mild;
  Vec3 tip = Vec3::Zero();  ///< mm, world
  int lesion = -1;          ///< 1-based lesion number it marked, -1: none
  double distance = 0.0;    ///< mm to that (or the nearest) lesion
  MarkVerdict verdict = MarkVerdict::False;
};

/// A moment the explorer went into a lesion (the recording's `penetration` episodes).
struct Insertion {
  double t = 0.0;         ///< s, servo time it entered
  int lesion = -1;        ///< 1-based lesion number
  double depth = 0.0;     ///< mm, the deepest it went
  double duration = 0.0;  ///< s, until it was back out
};

/// The debrief of one diagnosis case: the lesions revealed beside the marks, the insertions, and
/// the scores as plain sentences.
struct Debrief {
  std::vector<DebriefLesion> lesions;
  std::vector<DebriefMark> marks;
  std::vector<Insertion> insertions;
  /// The scores in words a trainee understands, in reading order ("You found 1 of 2 lesions.").
  std::vector<std::string> lines;
  double case_time = 0.0;   ///< s
  double time_limit = 0.0;  ///< s, 0: none
};

/// The debrief of a diagnosis trial from its answers (as stored), its scores (TrialResult::scores or
/// the scores table) and, when given, its recording (the insertions). Throws cariesim::Error for a
/// trial that is not a diagnosis one or answers that do not fit it (a mark naming a lesion the
/// case lacks).
Debrief make_debrief(const TrialSetup& setup, const DiagnosisAnswers& answers,
                     const std::vector<Score>& scores, const Recording* recording,
                     const ScoringDesc& scoring);

}  // namespace cariesim::training
