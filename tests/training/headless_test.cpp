// Whole studies headless (src/training/headless.cpp): real scenes built, a scripted device driving a
// recorded servo loop per trial, answers from a file, scores checked against the known answers.
#include "cariesim/training/headless.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/record/recorder.hpp"
#include "support/fifo.hpp"
#include "training/scores.hpp"
#include "training/study_schema.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;

RunOptions options(const fs::path& db, std::optional<int> trials = std::nullopt) {
  RunOptions o;
  o.participant = "P01";
  o.database = db;
  o.trials = trials;
  return o;
}

// The value of score `name` (level `level`) of a result.
double score(const TrialResult& r, std::string_view name, std::string_view level = "") {
  for (const Score& s : r.scores)
    if (s.name == name && s.level == level) return s.value;
  ADD_FAILURE() << "no score " << name << " " << level;
  return -1.0;
}

// An answers file naming the shapes of every trial: the truth, except cube `wrong_cube` of trial
// `wrong_trial`, which is given its neighbour's shape.
ScriptedAnswers boundary_answers(const Study& study, const StudyRun& run, int trials, int wrong_trial,
                                 int wrong_cube) {
  std::string yaml = "trials:\n";
  for (int i = 0; i < trials; ++i) {
    std::vector<std::string> shapes = make_trial(study, i, run.seed_of_trial(i)).truth.shapes;
    if (i == wrong_trial)
      shapes[static_cast<std::size_t>(wrong_cube)] = shapes[static_cast<std::size_t>(wrong_cube + 1) % 3];
    yaml += fmt::format("  - shapes: [{}, {}, {}]\n", shapes[0], shapes[1], shapes[2]);
  }
  return parse_answers(yaml, "answers.yaml");
}

TEST(Headless, BoundaryAllRightScoresTenOfTenAndOneWrongShapeLosesThatPoint) {
  const fs::path dir = test::scratch();
  const Study study = load_study((test::examples() / "boundary-small.yaml").string());
  HeadlessOptions headless;
  headless.device = "null";
  headless.duration = 0.1;
  for (const int wrong : {-1, 3}) {
    SCOPED_TRACE(wrong);
    const fs::path db = dir / fmt::format("class{}.db", wrong);
    StudyRun run(study, options(db, 10));
    const auto results = run_headless(run, boundary_answers(study, run, 10, wrong, 1), headless);
    ASSERT_EQ(results.size(), 10u);
    double points = 0.0;
    for (const TrialResult& r : results) points += score(r, kScoreBoundaryPoint);
    EXPECT_EQ(points, wrong < 0 ? 10.0 : 9.0);
    if (wrong >= 0) {
      EXPECT_EQ(score(results[3], kScoreBoundaryPoint), 0.0);
      const std::string hidden = make_trial(study, 3, run.seed_of_trial(3)).truth.shapes[1];
      EXPECT_EQ(score(results[3], kScoreShapeCorrect, hidden), 0.0);
    }
    // Every trial has its recording of the session (0.1 s at 1 kHz) beside the database. The span is
    // checked, not the count: a loaded machine may skip late servo cycles (their deadlines stay).
    EXPECT_EQ(test::query(db, "SELECT sum(value) FROM scores WHERE name = 'boundary_point'")[0][0],
              wrong < 0 ? "10.0" : "9.0");
    const Recording rec = load_recording(dir / results[9].recording);
    ASSERT_FALSE(rec.samples.empty());
    EXPECT_GE(rec.samples.back().t - rec.samples.front().t, 0.09);
    EXPECT_FALSE(rec.info.ended_at.empty());
  }
}

TEST(Headless, TuningRecordsTheConfirmedValuesOfBothLevels) {
  const fs::path dir = test::scratch();
  const Study study = load_study((test::examples() / "tuning-small.yaml").string());
  StudyRun run(study, options(dir / "class.db"));
  HeadlessOptions headless;
  headless.device = "scripted:" + (test::examples() / "slide-block.csv").string();
  const auto results = run_headless(run, load_answers(test::examples() / "tuning-answers.yaml"), headless);
  ASSERT_EQ(results.size(), 2u);
  for (const TrialResult& r : results) {
    EXPECT_EQ(score(r, kScoreMuS, "mild"), 0.18);
    EXPECT_EQ(score(r, kScoreMuD, "mild"), 0.17);
    EXPECT_EQ(score(r, kScoreMuS, "severe"), 0.51);
    EXPECT_EQ(score(r, kScoreMuD, "severe"), 0.45);
    // The slide touched the block: the recording has contact with its caries layer.
    const Recording rec = load_recording(dir / r.recording);
    EXPECT_TRUE(std::any_of(rec.samples.begin(), rec.samples.end(),
                            [](const ServoSample& s) { return s.lesion == 0 && s.contacts > 0; }));
  }
  EXPECT_EQ(test::query(dir / "class.db", "SELECT count(*) FROM scores WHERE name IN ('mu_s', 'mu_d')")[0][0],
            "8");
}

TEST(Headless, DiagnosisMarkOnTheLesionDetectsItAndOneThreeMillimetresAwayIsFalse) {
  const fs::path dir = test::scratch();
  const Study study = load_study((test::examples() / "diagnosis-small.yaml").string());
  StudyRun run(study, options(dir / "class.db"));
  HeadlessOptions headless;
  headless.device = "scripted:" + (test::examples() / "probe-fossa.csv").string();
  const auto results = run_headless(run, load_answers(test::examples() / "diagnosis-answers.yaml"), headless);
  ASSERT_EQ(results.size(), 1u);
  const TrialResult& r = results[0];
  EXPECT_EQ(score(r, kScoreLesions), 1.0);
  EXPECT_EQ(score(r, kScoreDetected), 1.0);
  EXPECT_EQ(score(r, kScoreMissed), 0.0);
  EXPECT_EQ(score(r, kScoreFalseMarks), 1.0);
  EXPECT_EQ(score(r, kScoreSeverityAccuracy), 1.0);
  EXPECT_EQ(score(r, kScoreTimeToDetection, "severe"), 0.9);
  EXPECT_EQ(score(r, kScoreCaseTime), 1.0);
  EXPECT_EQ(score(r, kScoreSoftTissueTime), 0.0);
  // The first mark is the recorded tip resting on the lesion's floor of the fossa.
  ASSERT_EQ(r.answers.marks.size(), 2u);
  EXPECT_LT(r.answers.marks[0].tip.z(), 6.0);
  EXPECT_GT(r.answers.marks[0].tip.z(), 4.0);
}

TEST(Headless, DiagnosisPushIntoTheGingivaCountsSoftTissueTime) {
  const fs::path dir = test::scratch();
  const Study study = load_study((test::examples() / "diagnosis-small.yaml").string());
  StudyRun run(study, options(dir / "class.db"));
  // Down into the gingiva band 3 mm buccal of the tooth, 6 mm deep, and held.
  const fs::path path = dir / "gum.csv";
  std::ofstream(path) << "t,px,py,pz,qw,qx,qy,qz\n0,0,-8,6,0.965926,0,-0.258819,0\n"
                         "0.5,0,-8,-0.3,0.965926,0,-0.258819,0\n1.0,0,-8,-6.3,0.965926,0,-0.258819,0\n"
                         "1.3,0,-8,-6.3,0.965926,0,-0.258819,0\n";
  HeadlessOptions headless;
  headless.device = "scripted:" + path.string();
  const auto results = run_headless(run, parse_answers("trials:\n  - {}\n", "answers.yaml"), headless);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_GT(score(results[0], kScoreSoftTissueTime), 0.1);
  EXPECT_GT(score(results[0], kScoreSoftTissuePeak), 0.4);
  EXPECT_EQ(score(results[0], kScoreDetected), 0.0);
  EXPECT_EQ(score(results[0], kScoreMissed), 1.0);
}

TEST(Answers, ErrorsAreLocated) {
  const auto error = [](const std::string& yaml) {
    try {
      (void)parse_answers(yaml, "a.yaml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("trials:\n  - shape: [square]\n").find("a.yaml:2:5"), std::string::npos);
  EXPECT_NE(error("trials:\n  - marks: [{t: 1, grade: moderate}]\n").find("a.yaml:2:27"), std::string::npos)
      << error("trials:\n  - marks: [{t: 1, grade: moderate}]\n");
  EXPECT_NE(error("trials:\n  - tuning: {mild: {mu_s: x}}\n").find("a.yaml:2:27"), std::string::npos)
      << error("trials:\n  - tuning: {mild: {mu_s: x}}\n");
  EXPECT_NE(error("trials: []\n").find("at least one trial"), std::string::npos);
  EXPECT_NE(error("trials:\n  - marks: [{t: -1, grade: mild}]\n").find("a.yaml:2:17"), std::string::npos)
      << error("trials:\n  - marks: [{t: -1, grade: mild}]\n");
}

// Issue 26 item 15: `study run --answers FIFO` blocked forever. The answers file is refused naming
// its kind.
TEST(Answers, AFifoIsRefusedWithoutBlocking) {
  const fs::path fifo = test::scratch() / "answers.yaml";
  ASSERT_TRUE(cariesim::test::make_fifo(fifo));
  const cariesim::test::FifoOutcome outcome =
      cariesim::test::read_fifo(fifo, [fifo] { (void)load_answers(fifo); });
  EXPECT_FALSE(outcome.blocked) << "load_answers blocked on a FIFO";
  EXPECT_NE(outcome.error.find(fifo.string() + ": answers: not a regular file (a FIFO (named pipe))"),
            std::string::npos)
      << outcome.error;
}

TEST(Headless, AnswersThatDoNotFitTheTrialNameTheTrialAndTheEntry) {
  const fs::path dir = test::scratch();
  const Study study = load_study((test::examples() / "boundary-small.yaml").string());
  StudyRun run(study, options(dir / "class.db", 1));
  HeadlessOptions headless;
  headless.duration = 0.05;
  try {
    run_headless(run, parse_answers("trials:\n  - shapes: [square, circle]\n", "answers.yaml"), headless);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("trial 1 (answers.yaml:2:5)"), std::string::npos) << msg;
    EXPECT_NE(msg.find("2 shapes named for 3 cubes"), std::string::npos) << msg;
  }
  EXPECT_EQ(test::query(dir / "class.db", "SELECT ended_at FROM trials")[0][0], "NULL");
}

}  // namespace
}  // namespace cariesim::training

namespace cariesim::training {
namespace {

TEST(ButtonMarks, PressesOfTheTwoButtonsAreMarksAtTheTip) {
  Recording r;
  r.samples.resize(10);
  for (std::size_t i = 0; i < r.samples.size(); ++i) {
    r.samples[i].t = 0.1 * static_cast<double>(i);
    r.samples[i].graphic.p = Vec3(static_cast<double>(i), 0.0, 0.0);
  }
  // Button 0 held over samples 2-4 (one press), button 2 pressed at 6 and again at 8, button 1 at 7.
  for (const std::size_t i : {2, 3, 4}) r.samples[i].buttons = 1u;
  r.samples[6].buttons = 4u;
  r.samples[7].buttons = 2u;
  r.samples[8].buttons = 4u;
  const std::vector<Mark> marks = marks_from_buttons(r, 0, 2);
  ASSERT_EQ(marks.size(), 3u);
  EXPECT_EQ(marks[0].grade, Grade::Mild);
  EXPECT_EQ(marks[0].tip, Vec3(2.0, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(marks[0].t, 0.2);
  EXPECT_EQ(marks[1].grade, Grade::Severe);
  EXPECT_DOUBLE_EQ(marks[1].t, 0.6);
  EXPECT_DOUBLE_EQ(marks[2].t, 0.8);
  EXPECT_TRUE(marks_from_buttons(r, -1, -1).empty());
}

TEST(Headless, DiagnosisMarksFromTheDeviceButtonsOfAReplayedSession) {
  const fs::path dir = test::scratch();
  // A session recorded as a trainee would: the probe-fossa path, button 0 pressed in the air at
  // 0.3 s (a false mild mark) and button 1 with the tip resting on the lesion at 0.9 s (severe).
  const fs::path session = dir / "trainee.db";
  {
    Recorder recorder(session, SessionInfo{});
    recorder.start();
    const Quat q(0.965926, 0.0, -0.258819, 0.0);
    for (int i = 0; i <= 1000; ++i) {
      const double t = 0.001 * i;
      const double z = t < 0.4 ? 12.0 - 4.5 * t / 0.4 : t < 0.8 ? 7.5 - 2.8 * (t - 0.4) / 0.4 : 4.7;
      ServoSample s;
      s.t = t;
      s.haptic = Pose{Vec3(0.0, 0.0, z), q.normalized()};
      s.graphic = s.haptic;
      s.buttons = (t >= 0.3 && t < 0.32 ? 1u : 0u) | (t >= 0.9 && t < 0.93 ? 2u : 0u);
      while (!recorder.queue().push(s)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    recorder.stop();
  }
  const Study study = load_study((test::examples() / "diagnosis-small.yaml").string());
  StudyRun run(study, options(dir / "class.db"));
  HeadlessOptions headless;
  headless.device = "replay:" + session.string();
  const auto results = run_headless(
      run, parse_answers("trials:\n  - {buttons: {mild: 0, severe: 1}, end: 1.0}\n", "answers.yaml"),
      headless);
  ASSERT_EQ(results.size(), 1u);
  const TrialResult& r = results[0];
  ASSERT_EQ(r.answers.marks.size(), 2u);
  EXPECT_EQ(r.answers.marks[0].grade, Grade::Mild);
  EXPECT_EQ(score(r, kScoreDetected), 1.0);
  EXPECT_EQ(score(r, kScoreFalseMarks), 1.0);
  EXPECT_EQ(score(r, kScoreSeverityAccuracy), 1.0);
  EXPECT_NEAR(score(r, kScoreTimeToDetection, "severe"), 0.9, 0.005);
}

}  // namespace
}  // namespace cariesim::training
