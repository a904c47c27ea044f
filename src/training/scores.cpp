// The scores of a trial (docs/training.md, "scores"): answers against the hidden truth, and the motion
// scores read from the trial's session recording.

#include "training/scores.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "cariesim/common/error.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace {

constexpr std::string_view kUnitless = "";
constexpr std::string_view kCount = "count";
constexpr std::string_view kFraction = "fraction";
constexpr std::string_view kSeconds = "s";
constexpr std::string_view kNewtons = "N";
// mm: a tool pressing with its tip this close to a lesion's volume, held off by another contact, is
// pressing on that lesion (a blocked insertion when it does not enter).
constexpr double kBlockedReach = 1.0;

Score make(std::string_view name, std::string_view level, double value, std::string_view unit) {
  return Score{std::string(name), std::string(level), value, std::string(unit)};
}

// Tuning (Tables 1-2): each level's confirmed values.
void tuning_scores(const TrialSetup& setup, const TrialAnswers& a, std::vector<Score>& out) {
  for (const Grade g : setup.levels) {
    const auto level = a.tuned.find(std::string(grade_name(g)));
    if (level == a.tuned.end())
      throw Error(fmt::format("tuning: the {} level was not confirmed", grade_name(g)));
    for (const TunedParameter& p : setup.parameters) {
      const auto v = level->second.find(p.name);
      if (v == level->second.end())
        throw Error(fmt::format("tuning: no {} confirmed for the {} level", p.name, grade_name(g)));
      out.push_back(make(p.name, grade_name(g), v->second, p.unit));
    }
  }
}

// Boundary (§4.2.2): each cube's answer, and one point when all are right. An unnamed cube is wrong.
void boundary_scores(const TrialSetup& setup, const TrialAnswers& a, std::vector<Score>& out) {
  bool all = true;
  for (std::size_t i = 0; i < setup.truth.shapes.size(); ++i) {
    const bool right = i < a.shapes.size() && a.shapes[i] == setup.truth.shapes[i];
    all = all && right;
    out.push_back(make(kScoreShapeCorrect, setup.truth.shapes[i], right ? 1.0 : 0.0, kUnitless));
  }
  out.push_back(make(kScoreBoundaryPoint, "", all ? 1.0 : 0.0, kUnitless));
}

// The case's end: the participant's end, else the recording's last sample, else the last mark.
double case_time(const TrialAnswers& a, const Recording* recording) {
  if (a.ended_at) return *a.ended_at;
  if (recording != nullptr && !recording->samples.empty()) return recording->samples.back().t;
  double t = 0.0;
  for (const Mark& m : a.marks) t = std::max(t, m.t);
  return t;
}

// The lesion a sample presses on: the one its tip touches while sliding, else (the tool held off by
// another contact) the nearest whose volume is within kBlockedReach of the graphic tip; -1 when none.
int pressed_lesion(const ServoSample& s, const std::vector<ScoredLesion>& lesions) {
  if (penetrating(s.state) || s.contacts == 0) return -1;
  if (s.lesion >= 0) return static_cast<std::size_t>(s.lesion) < lesions.size() ? s.lesion : -1;
  int nearest = -1;
  double best = kBlockedReach;
  for (std::size_t k = 0; k < lesions.size(); ++k) {
    const double d = lesions[k].shape.distance(s.graphic.p);
    if (d <= best) {
      best = d;
      nearest = static_cast<int>(k);
    }
  }
  return nearest;
}

// Blocked insertions (docs/training.md): presses on or next to a lesion at its F_p* or more, lasting
// at least blocked_min_duration, that end without the state turning to inserting (Fig. 17b).
int blocked_insertions(const Recording& recording, const std::vector<ScoredLesion>& lesions,
                       const ScoringDesc& scoring) {
  const double dt = recording.info.rate_hz > 0.0 ? 1.0 / recording.info.rate_hz : 0.001;
  int blocked = 0;
  int lesion = -1;       // the lesion of the open press, -1 when none
  double pressed = 0.0;  // s, how long the open press has lasted
  for (const ServoSample& s : recording.samples) {
    const int at = pressed_lesion(s, lesions);
    const double force = s.force.norm();
    if (lesion < 0) {
      // A press starts at F_p* on (or next to) a lesion.
      if (at >= 0 && force >= lesions[static_cast<std::size_t>(at)].f_p_star) {
        lesion = at;
        pressed = dt;
      }
      continue;
    }
    if (s.state == InteractionState::Inserting) {
      lesion = -1;  // it entered: not blocked
      continue;
    }
    if (at == lesion && force >= 0.5 * lesions[static_cast<std::size_t>(lesion)].f_p_star) {
      pressed += dt;
      continue;
    }
    // The press ended without entering.
    if (pressed >= scoring.blocked_min_duration) ++blocked;
    lesion = -1;
  }
  if (lesion >= 0 && pressed >= scoring.blocked_min_duration) ++blocked;
  return blocked;
}

// Diagnosis (§5.3): detections, misses, false marks, severity, times.
void diagnosis_scores(const Study& study, const TrialSetup& setup, const TrialAnswers& a,
                      const Recording* recording, const std::vector<ScoredLesion>& lesions,
                      std::vector<Score>& out) {
  if (lesions.size() != setup.truth.lesions.size())
    throw Error(fmt::format("diagnosis: {} lesions to score, the case has {}", lesions.size(),
                            setup.truth.lesions.size()));
  const std::vector<MarkJudgement> judged = judge_marks(a.marks, lesions, study.diagnosis.detection_margin);
  std::size_t detected = 0;
  std::size_t graded_right = 0;
  std::size_t false_marks = 0;
  std::vector<Score> times;
  for (std::size_t i = 0; i < judged.size(); ++i) {
    const MarkJudgement& j = judged[i];
    if (j.lesion < 0) {
      ++false_marks;
      continue;
    }
    if (!j.first) continue;
    ++detected;
    const ScoredLesion& l = lesions[static_cast<std::size_t>(j.lesion)];
    if (a.marks[i].grade == l.severity) ++graded_right;
    times.push_back(make(kScoreTimeToDetection, grade_name(l.severity), a.marks[i].t, kSeconds));
  }
  const std::size_t n = lesions.size();
  out.push_back(make(kScoreLesions, "", static_cast<double>(n), kCount));
  out.push_back(make(kScoreDetected, "", static_cast<double>(detected), kCount));
  out.push_back(make(kScoreMissed, "", static_cast<double>(n - detected), kCount));
  out.push_back(make(kScoreFalseMarks, "", static_cast<double>(false_marks), kCount));
  if (n > 0)
    out.push_back(
        make(kScoreDetectionRate, "", static_cast<double>(detected) / static_cast<double>(n), kFraction));
  if (detected > 0)
    out.push_back(make(kScoreSeverityAccuracy, "",
                       static_cast<double>(graded_right) / static_cast<double>(detected), kFraction));
  out.insert(out.end(), times.begin(), times.end());
  out.push_back(make(kScoreCaseTime, "", case_time(a, recording), kSeconds));
  if (recording != nullptr) {
    const std::vector<Score> motion = motion_scores(*recording, study.scoring);
    out.insert(out.end(), motion.begin(), motion.end());
    out.push_back(
        make(kScoreBlockedInsertions, "", blocked_insertions(*recording, lesions, study.scoring), kCount));
  }
}

}  // namespace

std::vector<Mark> marks_from_buttons(const Recording& recording, int mild_button, int severe_button) {
  // Rising edges of the two buttons, in sample order.
  const auto bit = [](int button) { return button >= 0 && button < 32 ? (1u << button) : 0u; };
  const uint32_t mild = bit(mild_button);
  const uint32_t severe = bit(severe_button);
  std::vector<Mark> marks;
  uint32_t last = 0;
  for (const ServoSample& s : recording.samples) {
    const uint32_t pressed = s.buttons & ~last;
    if ((pressed & mild) != 0) marks.push_back({s.graphic.p, Grade::Mild, s.t, s.contacts > 0});
    if ((pressed & severe) != 0) marks.push_back({s.graphic.p, Grade::Severe, s.t, s.contacts > 0});
    last = s.buttons;
  }
  return marks;
}

std::vector<MarkJudgement> judge_marks(const std::vector<Mark>& marks,
                                       const std::vector<ScoredLesion>& lesions, double margin) {
  // Each mark made in contact goes to the nearest lesion volume within the margin; only a lesion's
  // first mark counts.
  std::vector<MarkJudgement> out;
  std::vector<bool> found(lesions.size(), false);
  for (const Mark& m : marks) {
    MarkJudgement j;
    j.distance = std::numeric_limits<double>::infinity();
    int nearest = -1;
    for (std::size_t k = 0; k < lesions.size(); ++k) {
      const double d = std::max(0.0, lesions[k].shape.distance(m.tip));
      if (d < j.distance) {
        j.distance = d;
        nearest = static_cast<int>(k);
      }
    }
    if (nearest >= 0 && j.distance <= margin && m.contact) {
      j.lesion = nearest;
      j.first = !found[static_cast<std::size_t>(nearest)];
      found[static_cast<std::size_t>(nearest)] = true;
    }
    if (!std::isfinite(j.distance)) j.distance = -1.0;  // no lesion at all
    out.push_back(j);
  }
  return out;
}

std::vector<Score> motion_scores(const Recording& recording, const ScoringDesc& scoring) {
  // Time above the thresholds is counted one servo period per sample.
  const double dt = recording.info.rate_hz > 0.0 ? 1.0 / recording.info.rate_hz : 0.001;
  const double soft = scoring.soft_tissue_threshold.value_or(
      recording.soft_tissue_threshold > 0.0 ? recording.soft_tissue_threshold : 1.0);
  double soft_time = 0.0;
  double soft_peak = 0.0;
  double hard_time = 0.0;
  double hard_peak = 0.0;
  for (const ServoSample& s : recording.samples) {
    const double soft_force = std::isfinite(s.soft_tissue_force) ? s.soft_tissue_force : 0.0;
    soft_peak = std::max(soft_peak, soft_force);
    if (soft_force > soft) soft_time += dt;
    // Hard tissue: what the contacts push back with beyond the soft tissue, off the lesions.
    if (s.contacts > 0 && s.lesion < 0) {
      const double f = s.force.norm();
      const double hard = std::isfinite(f) ? std::max(0.0, f - soft_force) : 0.0;
      hard_peak = std::max(hard_peak, hard);
      if (hard > scoring.enamel_force_limit) hard_time += dt;
    }
  }
  return {make(kScoreSoftTissueTime, "", soft_time, kSeconds),
          make(kScoreSoftTissuePeak, "", soft_peak, kNewtons),
          make(kScoreEnamelExcessTime, "", hard_time, kSeconds),
          make(kScoreEnamelPeak, "", hard_peak, kNewtons)};
}

std::vector<Score> compute_scores(const Study& study, const TrialSetup& setup, const TrialAnswers& answers,
                                  const Recording* recording, const std::vector<ScoredLesion>& lesions) {
  std::vector<Score> out;
  switch (setup.kind) {
    case StudyKind::Tuning:
      tuning_scores(setup, answers, out);
      break;
    case StudyKind::Boundary:
      boundary_scores(setup, answers, out);
      break;
    case StudyKind::Diagnosis:
      diagnosis_scores(study, setup, answers, recording, lesions, out);
      break;
  }
  return out;
}

}  // namespace cariesim::training
