// Each built-in study end to end headless, one trial each (their scenes are the built-in scenes the
// other tests build, so the tree cache mostly hits): known answers, checked scores.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <functional>

#include "cariesim/scene/model_builder.hpp"
#include "cariesim/training/headless.hpp"
#include "training/study_schema.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;

double score(const TrialResult& r, std::string_view name, std::string_view level = "") {
  for (const Score& s : r.scores)
    if (s.name == name && s.level == level) return s.value;
  ADD_FAILURE() << "no score " << name << " " << level;
  return -1.0;
}

// One trial of built-in `name` with `answers` (YAML made from the trial's setup).
TrialResult run_one(const std::string& name, const fs::path& db,
                    const std::function<std::string(const TrialSetup&)>& answers) {
  RunOptions options;
  options.participant = "P01";
  options.database = db;
  options.trials = 1;
  options.seed = 11;
  StudyRun run(load_study(name), options);
  const Study& study = run.study();
  const TrialSetup setup = make_trial(study, 0, run.seed_of_trial(0));
  HeadlessOptions headless;
  headless.duration = 0.1;
  const auto results = run_headless(run, parse_answers(answers(setup), "answers.yaml"), headless);
  EXPECT_EQ(results.size(), 1u);
  return results.empty() ? TrialResult{} : results[0];
}

TEST(BuiltinHeadless, TuningAndTuningInsertionRecordTheConfirmedValues) {
  const fs::path dir = test::scratch();
  const TrialResult r = run_one("tuning", dir / "a.db", [](const TrialSetup&) {
    return "trials:\n  - tuning: {mild: {mu_s: 0.18, mu_d: 0.17}, severe: {mu_s: 0.51, mu_d: 0.45}}\n";
  });
  EXPECT_EQ(score(r, kScoreMuS, "mild"), 0.18);
  EXPECT_EQ(score(r, kScoreMuD, "severe"), 0.45);
  const TrialResult k = run_one("tuning-insertion", dir / "b.db", [](const TrialSetup&) {
    return "trials:\n  - tuning: {mild: {k_c: 0.58, k_e: 0.53}, severe: {k_c: 0.2, k_e: 0.38}}\n";
  });
  EXPECT_EQ(score(k, kScoreKc, "mild"), 0.58);
  EXPECT_EQ(score(k, kScoreKe, "severe"), 0.38);
}

TEST(BuiltinHeadless, BoundaryShapesAllRightScoresThePoint) {
  const fs::path dir = test::scratch();
  const TrialResult r = run_one("boundary-shapes", dir / "class.db", [](const TrialSetup& t) {
    return fmt::format("trials:\n  - shapes: [{}, {}, {}]\n", t.truth.shapes[0], t.truth.shapes[1],
                       t.truth.shapes[2]);
  });
  EXPECT_EQ(score(r, kScoreBoundaryPoint), 1.0);
  EXPECT_EQ(score(r, kScoreShapeCorrect, "square"), 1.0);
}

TEST(BuiltinHeadless, DiagnosisPaperMarksOnThePapersThreeLesionsDetectAndGradeThem) {
  const fs::path dir = test::scratch();
  // diagnosis-paper's first case is the paper's: #1 and #2 severe on 46, #3 mild on 36. Marks at the lesions'
  // centres as the model placed them (snapped onto the teeth), #3 graded wrong, plus one on 47.
  const TrialResult r = run_one("diagnosis-paper", dir / "class.db", [](const TrialSetup& t) {
    const Model model = build_model(t.scene());
    EXPECT_EQ(model.lesions.size(), 3u);
    std::string yaml = "trials:\n  - marks:\n";
    const char* grades[] = {"severe", "severe", "severe"};
    for (std::size_t k = 0; k < model.lesions.size() && k < 3; ++k) {
      const Vec3 c = model.lesions[k].shape.center;
      yaml += fmt::format("      - {{t: {}, at: [{}, {}, {}], grade: {}}}\n",
                          0.02 * static_cast<double>(k + 1), c.x(), c.y(), c.z(), grades[k]);
    }
    yaml += "      - {t: 0.09, at: [-25.0, 10.0, 7.0], grade: mild}\n";
    return yaml;
  });
  EXPECT_EQ(score(r, kScoreLesions), 3.0);
  EXPECT_EQ(score(r, kScoreDetected), 3.0);
  EXPECT_EQ(score(r, kScoreFalseMarks), 1.0);
  EXPECT_DOUBLE_EQ(score(r, kScoreSeverityAccuracy), 2.0 / 3.0);
  EXPECT_EQ(score(r, kScoreTimeToDetection, "mild"), 0.06);
}

}  // namespace
}  // namespace cariesim::training
