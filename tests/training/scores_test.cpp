// Scores (src/training/scores.cpp): marks judged against lesion volumes, the answers' scores and the
// motion scores of a recording, on hand-made inputs whose scores are counted by hand.
#include "training/scores.hpp"

#include <gtest/gtest.h>

#include "cariesim/common/error.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {
namespace {

// A 2.2 mm disk lesion, 2 mm deep, on the plane z = 0 at (x, 0, 0).
ScoredLesion disk(double x, Grade severity, double f_p_star = 2.0) {
  ScoredLesion l;
  l.shape.kind = LesionShape::Kind::Disk;
  l.shape.center = Vec3(x, 0.0, 0.0);
  l.shape.normal = Vec3::UnitZ();
  l.shape.size = 2.2;
  l.shape.depth = 2.0;
  l.severity = severity;
  l.f_p_star = f_p_star;
  return l;
}

// The value of score (name, level); fails the test when absent or repeated.
double value(const std::vector<Score>& scores, std::string_view name, std::string_view level = "") {
  const Score* found = nullptr;
  for (const Score& s : scores) {
    if (s.name != name || s.level != level) continue;
    EXPECT_EQ(found, nullptr) << name << " " << level << " twice";
    found = &s;
  }
  if (found == nullptr) {
    ADD_FAILURE() << "no score " << name << " " << level;
    return -1.0;
  }
  return found->value;
}

bool has(const std::vector<Score>& scores, std::string_view name) {
  return std::any_of(scores.begin(), scores.end(), [&](const Score& s) { return s.name == name; });
}

// A diagnosis study and trial with `lesions` (their truth) and no recording.
struct DiagnosisFixture {
  Study study;
  TrialSetup setup;
  explicit DiagnosisFixture(const std::vector<ScoredLesion>& lesions) {
    study.kind = StudyKind::Diagnosis;
    setup.kind = StudyKind::Diagnosis;
    for (const ScoredLesion& l : lesions) setup.truth.lesions.push_back({"site", l.severity, 2.2, 1.0, 2.0});
  }
};

TEST(JudgeMarks, OnTheLesionIsADetectionThreeMillimetresAwayIsNot) {
  const std::vector<ScoredLesion> lesions = {disk(0.0, Grade::Severe)};
  const std::vector<Mark> marks = {
      {Vec3(0.2, 0.1, 0.05), Grade::Severe, 1.0},  // on the lesion
      {Vec3(3.0, 0.0, 0.05), Grade::Mild, 2.0},    // 3 mm from its centre, 1.9 mm beyond its edge
      {Vec3(1.5, 0.0, 0.0), Grade::Mild, 3.0},     // 0.4 mm beyond the edge: within the margin
      {Vec3(0.0, 1.7, 0.0), Grade::Mild, 4.0},     // 0.6 mm beyond the edge: outside
  };
  const std::vector<MarkJudgement> j = judge_marks(marks, lesions, 0.5);
  ASSERT_EQ(j.size(), 4u);
  EXPECT_EQ(j[0].lesion, 0);
  EXPECT_TRUE(j[0].first);
  EXPECT_DOUBLE_EQ(j[0].distance, 0.0);
  EXPECT_EQ(j[1].lesion, -1);
  EXPECT_NEAR(j[1].distance, 1.9, 1e-9);
  EXPECT_EQ(j[2].lesion, 0);
  EXPECT_FALSE(j[2].first);  // the lesion was found already
  EXPECT_NEAR(j[2].distance, 0.4, 1e-9);
  EXPECT_EQ(j[3].lesion, -1);
  EXPECT_NEAR(j[3].distance, 0.6, 1e-9);
}

TEST(JudgeMarks, AMarkMadeInTheAirDetectsNothing) {
  // 2 mm above the lesion's centre lies inside its volume (which reaches above the surface), but
  // the tool touched nothing: a false mark.
  const std::vector<ScoredLesion> lesions = {disk(0.0, Grade::Severe)};
  const std::vector<MarkJudgement> j =
      judge_marks({{Vec3(0.0, 0.0, 2.0), Grade::Severe, 1.0, false}}, lesions, 0.5);
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0].lesion, -1);
  EXPECT_EQ(judge_marks({{Vec3(0.0, 0.0, 2.0), Grade::Severe, 1.0, true}}, lesions, 0.5)[0].lesion, 0);
}

TEST(JudgeMarks, AMarkGoesToTheNearestLesion) {
  const std::vector<ScoredLesion> lesions = {disk(0.0, Grade::Mild), disk(2.6, Grade::Severe)};
  // 1.35 mm from the first's centre (0.25 beyond its edge), 1.25 from the second's (0.15 beyond).
  const std::vector<MarkJudgement> j = judge_marks({{Vec3(1.35, 0.0, 0.0), Grade::Mild, 1.0}}, lesions, 0.5);
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0].lesion, 1);
}

TEST(DiagnosisScores, CountsDetectionsMissesFalseMarksSeverityAndTimes) {
  const std::vector<ScoredLesion> lesions = {disk(0.0, Grade::Severe), disk(10.0, Grade::Mild),
                                             disk(20.0, Grade::Severe)};
  DiagnosisFixture f(lesions);
  TrialAnswers a;
  a.marks = {
      {Vec3(0.0, 0.0, 0.05), Grade::Severe, 4.0},   // lesion 1, graded right
      {Vec3(10.3, 0.0, 0.05), Grade::Severe, 9.5},  // lesion 2, graded wrong
      {Vec3(10.0, 0.0, 0.05), Grade::Mild, 11.0},   // lesion 2 again: neither detection nor false
      {Vec3(5.0, 0.0, 0.05), Grade::Mild, 12.0},    // nothing there: false
  };
  a.ended_at = 30.0;
  const std::vector<Score> s = compute_scores(f.study, f.setup, a, nullptr, lesions);
  EXPECT_EQ(value(s, kScoreLesions), 3.0);
  EXPECT_EQ(value(s, kScoreDetected), 2.0);
  EXPECT_EQ(value(s, kScoreMissed), 1.0);
  EXPECT_EQ(value(s, kScoreFalseMarks), 1.0);
  EXPECT_DOUBLE_EQ(value(s, kScoreDetectionRate), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(value(s, kScoreSeverityAccuracy), 0.5);
  EXPECT_EQ(value(s, kScoreTimeToDetection, "severe"), 4.0);
  EXPECT_EQ(value(s, kScoreTimeToDetection, "mild"), 9.5);
  EXPECT_EQ(value(s, kScoreCaseTime), 30.0);
  EXPECT_FALSE(has(s, kScoreSoftTissueTime));  // no recording, no motion scores
}

TEST(DiagnosisScores, NoDetectionHasNoSeverityAccuracy) {
  const std::vector<ScoredLesion> lesions = {disk(0.0, Grade::Mild)};
  DiagnosisFixture f(lesions);
  TrialAnswers a;
  a.marks = {{Vec3(8.0, 0.0, 0.0), Grade::Mild, 2.0}};
  const std::vector<Score> s = compute_scores(f.study, f.setup, a, nullptr, lesions);
  EXPECT_EQ(value(s, kScoreDetected), 0.0);
  EXPECT_EQ(value(s, kScoreMissed), 1.0);
  EXPECT_FALSE(has(s, kScoreSeverityAccuracy));
  EXPECT_EQ(value(s, kScoreCaseTime), 2.0);  // no end and no recording: the last mark
}

TEST(BoundaryScores, OnePointOnlyWhenAllThreeAreRight) {
  Study study;
  study.kind = StudyKind::Boundary;
  TrialSetup t;
  t.kind = StudyKind::Boundary;
  t.truth.shapes = {"circle", "square", "triangle"};
  TrialAnswers a;
  a.shapes = {"circle", "square", "triangle"};
  std::vector<Score> s = compute_scores(study, t, a, nullptr, {});
  EXPECT_EQ(value(s, kScoreBoundaryPoint), 1.0);
  EXPECT_EQ(value(s, kScoreShapeCorrect, "square"), 1.0);
  a.shapes = {"circle", "triangle", "square"};
  s = compute_scores(study, t, a, nullptr, {});
  EXPECT_EQ(value(s, kScoreBoundaryPoint), 0.0);
  EXPECT_EQ(value(s, kScoreShapeCorrect, "circle"), 1.0);
  EXPECT_EQ(value(s, kScoreShapeCorrect, "square"), 0.0);
  EXPECT_EQ(value(s, kScoreShapeCorrect, "triangle"), 0.0);
  a.shapes = {"circle", "square", ""};  // a cube left unnamed is wrong
  s = compute_scores(study, t, a, nullptr, {});
  EXPECT_EQ(value(s, kScoreBoundaryPoint), 0.0);
}

TEST(TuningScores, TheConfirmedValuesPerLevelAndAnUnconfirmedLevelIsAnError) {
  Study study;
  TrialSetup t;
  t.kind = StudyKind::Tuning;
  t.levels = {Grade::Severe, Grade::Mild};
  t.parameters = {{"k_c", "N/mm", 0.05, 2.0, 1.0}, {"k_e", "N/mm", 0.05, 2.0, 1.0}};
  TrialAnswers a;
  a.tuned["severe"] = {{"k_c", 0.2}, {"k_e", 0.38}};
  EXPECT_THROW((void)compute_scores(study, t, a, nullptr, {}), Error);
  a.tuned["mild"] = {{"k_c", 0.58}, {"k_e", 0.53}};
  const std::vector<Score> s = compute_scores(study, t, a, nullptr, {});
  EXPECT_EQ(s.size(), 4u);
  EXPECT_EQ(value(s, kScoreKc, "mild"), 0.58);
  EXPECT_EQ(value(s, kScoreKe, "severe"), 0.38);
  EXPECT_EQ(s.front().unit, "N/mm");
}

// A recording at 1 kHz of `n` free samples.
Recording recording(std::size_t n) {
  Recording r;
  r.info.rate_hz = 1000.0;
  r.soft_tissue_threshold = 1.0;
  r.samples.resize(n);
  for (std::size_t i = 0; i < n; ++i) r.samples[i].t = 0.001 * static_cast<double>(i);
  return r;
}

TEST(MotionScores, SoftTissueAndHardTissueForcesAboveTheirThresholds) {
  Recording r = recording(1000);
  // 120 ms pressing the gingiva at 1.5 N (peak 2.5 N), then 40 ms at 0.8 N (below 1 N).
  for (std::size_t i = 100; i < 220; ++i) {
    r.samples[i].soft_tissue_force = i == 150 ? 2.5f : 1.5f;
    r.samples[i].contacts = 1;
    r.samples[i].force = Vec3(0.0, 0.0, 1.5);
  }
  for (std::size_t i = 300; i < 340; ++i) r.samples[i].soft_tissue_force = 0.8f;
  // 30 ms pushing on enamel at 6 N (limit 4 N), 20 ms at 3 N, and 10 ms at 9 N on a lesion (not enamel).
  for (std::size_t i = 500; i < 530; ++i) {
    r.samples[i].contacts = 2;
    r.samples[i].force = Vec3(0.0, 6.0, 0.0);
  }
  for (std::size_t i = 600; i < 620; ++i) {
    r.samples[i].contacts = 1;
    r.samples[i].force = Vec3(3.0, 0.0, 0.0);
  }
  for (std::size_t i = 700; i < 710; ++i) {
    r.samples[i].contacts = 1;
    r.samples[i].lesion = 0;
    r.samples[i].force = Vec3(0.0, 0.0, 9.0);
  }
  ScoringDesc scoring;
  std::vector<Score> s = motion_scores(r, scoring);
  EXPECT_NEAR(value(s, kScoreSoftTissueTime), 0.120, 1e-9);
  EXPECT_NEAR(value(s, kScoreSoftTissuePeak), 2.5, 1e-6);
  EXPECT_NEAR(value(s, kScoreEnamelExcessTime), 0.030, 1e-9);
  EXPECT_NEAR(value(s, kScoreEnamelPeak), 6.0, 1e-6);
  // The study's threshold replaces the recording's.
  scoring.soft_tissue_threshold = 0.5;
  s = motion_scores(r, scoring);
  EXPECT_NEAR(value(s, kScoreSoftTissueTime), 0.160, 1e-9);
}

TEST(MotionScores, BlockedInsertionsArePressesAtThresholdThatDoNotEnter) {
  const std::vector<ScoredLesion> lesions = {disk(0.0, Grade::Severe, 2.0)};
  DiagnosisFixture f(lesions);
  Recording r = recording(2000);
  const auto press = [&](std::size_t from, std::size_t to, double force) {
    for (std::size_t i = from; i < to; ++i) {
      r.samples[i].state = InteractionState::Sliding;
      r.samples[i].lesion = 0;
      r.samples[i].contacts = 3;
      r.samples[i].force = Vec3(0.0, 0.0, force);
    }
  };
  press(100, 200, 2.4);  // 100 ms at F_p* without entering: blocked
  press(400, 420, 2.4);  // 20 ms: too short to count
  press(600, 700, 1.5);  // below F_p*: not a press
  press(900, 960, 2.2);  // 60 ms, then it enters: not blocked
  for (std::size_t i = 960; i < 1100; ++i) {
    r.samples[i].state = InteractionState::Inserting;
    r.samples[i].lesion = 0;
  }
  // 80 ms held off by another contact with the tip 0.5 mm beside the lesion (the shank against a
  // neighbour, Fig. 17b): blocked; the same 3 mm away: not a press on the lesion.
  const auto held_off = [&](std::size_t from, std::size_t to, double x) {
    for (std::size_t i = from; i < to; ++i) {
      r.samples[i].state = InteractionState::Sliding;
      r.samples[i].contacts = 2;
      r.samples[i].graphic.p = Vec3(x, 0.0, 0.05);
      r.samples[i].force = Vec3(0.0, 0.0, 2.5);
    }
  };
  held_off(1200, 1280, 1.6);
  held_off(1300, 1400, 4.1);
  press(1500, 2000, 3.0);  // until the recording ends: blocked
  const std::vector<Score> s = compute_scores(f.study, f.setup, TrialAnswers{}, &r, lesions);
  EXPECT_EQ(value(s, kScoreBlockedInsertions), 3.0);
  EXPECT_NEAR(value(s, kScoreCaseTime), 1.999, 1e-9);  // no end: the last sample
}

}  // namespace
}  // namespace cariesim::training
