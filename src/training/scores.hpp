#pragma once
/// The scores of a trial (docs/training.md defines each), computed from its session recording and the
/// participant's answers. The names are the kScore* of src/training/study_schema.hpp.
///
/// Tuning (Tables 1-2): the confirmed values per level. Boundary (§4.2.2): shape_correct per cube
/// and boundary_point. Diagnosis (§5.3): detections (a mark within the lesion's footprint plus the
/// study's detection margin), misses, false marks, severity accuracy, time to each detection, case
/// time; and from the motion: soft-tissue damage (time and peak force on gingiva/tongue above the
/// threshold), excess force on hard tissue, blocked insertions (a press on caries at F_p* that did
/// not enter: a wrong posture, Fig. 17b).

#include <vector>

#include "cariesim/record/recorder.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "cariesim/training/run.hpp"
#include "cariesim/training/study.hpp"

namespace cariesim::training {

/// One lesion of the trial's scene as the scorer sees it.
struct ScoredLesion {
  LesionShape shape;  ///< world, snapped onto the surface (Model::lesions[i].shape)
  Grade severity = Grade::Mild;
  double f_p_star = 0.0;  ///< N, the insertion threshold of its material (blocked insertions)
};

/// How each diagnosis mark was judged.
struct MarkJudgement {
  int lesion = -1;        ///< the lesion it detected (nearest within the margin), -1: a false mark
  double distance = 0.0;  ///< mm, from the tip to that lesion's volume (or to the nearest lesion)
  bool first = false;     ///< the first mark on that lesion (later ones neither count nor are false)
};

/// The marks a recording's device buttons made (docs/training.md, "answers files"): a press (the
/// button's bit going from 0 to 1) of `mild_button` or `severe_button` (bit indices, 0-31) is a mark
/// of that grade at the sample's graphic tip and time. A button index < 0 is not used.
std::vector<Mark> marks_from_buttons(const Recording& recording, int mild_button, int severe_button);

/// Judges each mark against the lesions (docs/training.md, "detection").
std::vector<MarkJudgement> judge_marks(const std::vector<Mark>& marks,
                                       const std::vector<ScoredLesion>& lesions, double margin);

/// The scores of one trial. `recording` may be null (no motion scores then); `lesions` are needed
/// for a diagnosis trial (one per TrialTruth::lesions entry, same order). Throws cariesim::Error
/// when the answers are incomplete for the trial's kind.
std::vector<Score> compute_scores(const Study& study, const TrialSetup& setup, const TrialAnswers& answers,
                                  const Recording* recording, const std::vector<ScoredLesion>& lesions);

/// The motion scores of a recording alone (soft tissue, enamel excess, blocked insertions), for any
/// session recording: `soft_tissue_threshold` unset takes the recording's.
std::vector<Score> motion_scores(const Recording& recording, const ScoringDesc& scoring);

}  // namespace cariesim::training
