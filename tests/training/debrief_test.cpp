// Trials rebuilt from the study database alone (rebuild_trial, check_rebuilt_scene), a tampered
// database refused by name, version 1 databases, the study file's `debrief:` and the debrief of a
// case (include/cariesim/training/debrief.hpp).
#include "cariesim/training/debrief.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>

#include "cariesim/common/error.hpp"
#include "cariesim/io/sqlite.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/training/headless.hpp"
#include "cariesim/training/report.hpp"
#include "training/study_schema.hpp"
#include "training/training_support.hpp"

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;

// diagnosis-small with drawn cases after its listed one: trial 2 onward is drawn from its seed.
std::string drawn_study_yaml() {
  return fmt::format(
      "name: drawn-small\nkind: diagnosis\ntrials: 2\nseed: 11\n"
      "diagnosis:\n  scene: {}\n  time_limit: 10.0\n"
      "  sites:\n"
      "    - {{name: 46-occlusal, object: tooth46, site: occlusal, at: [0.0, 0.0, 7.0], normal: [0, 0, 1], "
      "snap_range: 3.0, shape: disk}}\n"
      "    - {{name: 46-mesial, object: tooth46, site: interproximal, at: [4.9, 0.0, 6.4], normal: [1.0, "
      "0.0, "
      "1.2], tangent: [0, 1, 0], snap_range: 2.5, shape: stripe}}\n"
      "  cases:\n    - lesions:\n        - {{site: 46-occlusal, severity: severe, size: 2.2, depth: 2.0}}\n"
      "  generate: {{count: [2, 2], size: [1.6, 2.4], mild_depth: [0.6, 1.0], severe_depth: [1.3, 1.8]}}\n",
      (test::examples() / "one-molar.yaml").string());
}

// Runs the drawn study headless for P01 (two trials, the fossa probe, one mark each) into `db`.
std::vector<TrialResult> run_drawn(const fs::path& dir, const fs::path& db) {
  const fs::path file = dir / "drawn-small.yaml";
  std::ofstream(file) << drawn_study_yaml();
  RunOptions o;
  o.participant = "P01";
  o.database = db;
  StudyRun run(load_study(file.string()), o);
  HeadlessOptions headless;
  headless.device = "scripted:" + (test::examples() / "probe-fossa.csv").string();
  return run_headless(run, load_answers(test::examples() / "diagnosis-answers.yaml"), headless);
}

// The message of the cariesim::Error `f` throws ("" when it throws none).
template <typename F>
std::string error_of(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Rebuild, ADrawnCaseRebuildsFromTheDatabaseWithTheRecordedSceneHash) {
  const fs::path dir = test::scratch();
  const fs::path db = dir / "class.db";
  const std::vector<TrialResult> results = run_drawn(dir, db);
  ASSERT_EQ(results.size(), 2u);
  // The study file is gone: the database alone holds its text.
  fs::remove(dir / "drawn-small.yaml");

  const RebuiltTrial t = rebuild_trial(db, "P01", 2);
  EXPECT_EQ(t.row, results[1].row);
  EXPECT_EQ(t.run_trial, 2);
  EXPECT_EQ(t.seed, results[1].seed);
  // A drawn case (two lesions), not the listed one; the same case as when it ran.
  ASSERT_EQ(t.setup.truth.lesions.size(), 2u);
  const Study original = parse_study(drawn_study_yaml(), dir / "drawn-small.yaml");
  const TrialSetup ran = make_trial(original, 1, results[1].seed);
  EXPECT_EQ(t.setup.scene_yaml, ran.scene_yaml);
  // Its scene, built, has the hash the recording was made on.
  const Recording recording = load_recording(t.recording);
  const Model model = build_model(t.setup.scene());
  EXPECT_EQ(model.scene_hash, recording.info.scene_hash);
  ASSERT_TRUE(t.scene_hash.has_value());
  EXPECT_EQ(*t.scene_hash, recording.info.scene_hash);
  EXPECT_NO_THROW(check_rebuilt_scene(t, model, &recording.info));
  // The first trial's scene (the listed case) is another scene.
  EXPECT_NE(rebuild_trial(db, "P01", 1).setup.scene_yaml, t.setup.scene_yaml);
  // Without a number: the participant's last ended trial; without a participant: the only one.
  EXPECT_EQ(rebuild_trial(db).row, results[1].row);
  // The marks as judged when it ran.
  ASSERT_EQ(t.answers.marks.size(), 2u);
  EXPECT_EQ(t.answers.marks[0].mark.t, results[1].answers.marks[0].t);
}

TEST(Rebuild, ATamperedRowIsRefusedNamingIt) {
  const fs::path dir = test::scratch();
  const fs::path db = dir / "class.db";
  const std::vector<TrialResult> results = run_drawn(dir, db);
  ASSERT_EQ(results.size(), 2u);
  const std::string row = std::to_string(results[1].row);

  // Another seed: another drawn case than the one stored with the marks.
  test::query(db, "UPDATE trials SET seed = seed + 1 WHERE id = " + row);
  const std::string seed = error_of([&] { (void)rebuild_trial(db, "P01", 2); });
  EXPECT_NE(seed.find("trials, row " + row + ", column answers"), std::string::npos) << seed;
  EXPECT_NE(seed.find("is not the case seed"), std::string::npos) << seed;
  test::query(db, "UPDATE trials SET seed = seed - 1 WHERE id = " + row);
  EXPECT_NO_THROW((void)rebuild_trial(db, "P01", 2));

  // The stored place of a lesion moved 0.01 mm within its site's region: not the drawn case either.
  auto shift = [&](const std::string& sign) {
    return "UPDATE trials SET answers = json_set(answers, '$.lesions[0].offset[0]', json_extract(answers, "
           "'$.lesions[0].offset[0]') " +
           sign + " 0.01) WHERE id = " + row;
  };
  test::query(db, shift("+"));
  const std::string moved = error_of([&] { (void)rebuild_trial(db, "P01", 2); });
  EXPECT_NE(moved.find("is not the case seed"), std::string::npos) << moved;
  test::query(db, shift("-"));
  EXPECT_NO_THROW((void)rebuild_trial(db, "P01", 2));

  // The study's text edited (a longer time limit) without its hash.
  test::query(db, "UPDATE studies SET yaml = replace(yaml, 'time_limit: 10.0', 'time_limit: 99.0')");
  const std::string text = error_of([&] { (void)rebuild_trial(db, "P01", 2); });
  EXPECT_NE(text.find("studies, row 1, column yaml"), std::string::npos) << text;
  EXPECT_NE(text.find("the text was changed"), std::string::npos) << text;
  test::query(db, "UPDATE studies SET yaml = replace(yaml, 'time_limit: 99.0', 'time_limit: 10.0')");

  // A seed stored as text; a scene hash that is not one.
  test::query(db, "UPDATE trials SET seed = 'x' WHERE id = " + row);
  const std::string type = error_of([&] { (void)rebuild_trial(db, "P01", 2); });
  EXPECT_NE(type.find("trials, row " + row + ", column seed: stored as TEXT"), std::string::npos) << type;
  test::query(db, fmt::format("UPDATE trials SET seed = {} WHERE id = {}", results[1].seed, row));
  test::query(db, "UPDATE trial_sources SET scene_hash = 'zz' WHERE trial_id = " + row);
  const std::string hash = error_of([&] { (void)rebuild_trial(db, "P01", 2); });
  EXPECT_NE(hash.find("trial_sources, row " + row + ", column scene_hash"), std::string::npos) << hash;

  // A well-formed scene hash of another scene: the rebuilt model does not match it.
  test::query(db, "UPDATE trial_sources SET scene_hash = '0123456789abcdef' WHERE trial_id = " + row);
  const RebuiltTrial t = rebuild_trial(db, "P01", 2);
  const Model model = build_model(t.setup.scene());
  const std::string scene = error_of([&] { check_rebuilt_scene(t, model, nullptr); });
  EXPECT_NE(scene.find("trial_sources, row " + row + ", column scene_hash"), std::string::npos) << scene;
  EXPECT_NE(scene.find("0123456789abcdef"), std::string::npos) << scene;
  // A recording of another scene.
  SessionInfo other;
  other.scene_hash = model.scene_hash ^ 1;
  RebuiltTrial unhashed = t;
  unhashed.scene_hash.reset();
  const std::string rec = error_of([&] { check_rebuilt_scene(unhashed, model, &other); });
  EXPECT_NE(rec.find("session.scene_hash"), std::string::npos) << rec;

  // Marks that are not JSON of the answers.
  test::query(db, "UPDATE trials SET answers = '{\"lesions\": [], \"marks\": 3}' WHERE id = " + row);
  const std::string answers = error_of([&] { (void)rebuild_trial(db, "P01", 2); });
  EXPECT_NE(answers.find("trials, row " + row + ", column answers"), std::string::npos) << answers;
}

TEST(Rebuild, NoSuchParticipantOrTrialIsSaidSo) {
  const fs::path dir = test::scratch();
  const fs::path db = dir / "class.db";
  (void)run_drawn(dir, db);
  EXPECT_NE(error_of([&] { (void)rebuild_trial(db, "P09"); }).find("no trial of participant 'P09'"),
            std::string::npos);
  EXPECT_NE(error_of([&] { (void)rebuild_trial(db, "P01", 3); }).find("has 2 trials, not 3"),
            std::string::npos);
}

// The study database of schema version 1 (before the study's text was stored).
constexpr const char* kVersion1Sql =
    "CREATE TABLE schema_version (version INTEGER NOT NULL, application TEXT NOT NULL);"
    "CREATE TABLE trials (id INTEGER PRIMARY KEY, station TEXT NOT NULL, participant TEXT NOT NULL,"
    " study TEXT NOT NULL, kind TEXT NOT NULL, trial INTEGER NOT NULL, seed INTEGER NOT NULL,"
    " started_at TEXT NOT NULL, ended_at TEXT, recording TEXT, answers TEXT NOT NULL,"
    " scores TEXT NOT NULL);"
    "CREATE TABLE scores (trial_id INTEGER NOT NULL REFERENCES trials(id), name TEXT NOT NULL,"
    " level TEXT NOT NULL, value REAL NOT NULL, unit TEXT NOT NULL);"
    "CREATE INDEX scores_by_trial ON scores (trial_id);"
    "PRAGMA application_id=1129468756;"
    "INSERT INTO schema_version VALUES (1, 'cariesim-study');"
    "INSERT INTO trials VALUES (1, 's', 'P01', 'diagnosis-small', 'diagnosis', 1, 5, '2026-01-01T00:00:00Z',"
    " '2026-01-01T00:01:00Z', NULL, '{}', '{}');";

TEST(Rebuild, AVersion1DatabaseIsReadAppendedToAndItsOldTrialsRefusedClearly) {
  const fs::path dir = test::scratch();
  const fs::path db = dir / "old.db";
  {
    io::Database d(db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    d.exec(kVersion1Sql, "make a version 1 database");
  }
  // The report still reads it.
  EXPECT_EQ(read_study_database(db).size(), 1u);
  const std::string old = error_of([&] { (void)rebuild_trial(db, "P01", 1); });
  EXPECT_NE(old.find("schema version 1"), std::string::npos) << old;
  EXPECT_NE(old.find("cannot be rebuilt"), std::string::npos) << old;

  // A run appends to it (adding the version 2 tables); its trial rebuilds, the old one still not.
  {
    RunOptions o;
    o.participant = "P01";
    o.database = db;
    StudyRun run(load_study((test::examples() / "diagnosis-small.yaml").string()), o);
    HeadlessOptions headless;
    headless.device = "scripted:" + (test::examples() / "probe-fossa.csv").string();
    ASSERT_EQ(run_headless(run, load_answers(test::examples() / "diagnosis-answers.yaml"), headless).size(),
              1u);
  }
  EXPECT_EQ(test::query(db, "SELECT version FROM schema_version"),
            (std::vector<std::vector<std::string>>{{"2"}}));
  EXPECT_EQ(rebuild_trial(db, "P01", 2).setup.truth.lesions.size(), 1u);
  const std::string still = error_of([&] { (void)rebuild_trial(db, "P01", 1); });
  EXPECT_NE(still.find("has no row in trial_sources"), std::string::npos) << still;
  EXPECT_EQ(read_study_database(db).size(), 2u);

  // A file that says version 2 without the version 2 tables is not a study database.
  const fs::path lying = dir / "lying.db";
  {
    io::Database d(lying, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
    d.exec(kVersion1Sql, "make a version 1 database");
    d.exec("UPDATE schema_version SET version = 2", "claim version 2");
  }
  const std::string lie = error_of([&] { (void)rebuild_trial(lying, "P01", 1); });
  EXPECT_NE(lie.find("the table 'studies' is missing"), std::string::npos) << lie;
}

TEST(StudyDebrief, TheStudyFileSaysWhenAndIsCheckedAtItsLine) {
  const std::string base = drawn_study_yaml();
  EXPECT_EQ(parse_study(base, "s.yaml").debrief, DebriefWhen::Never);
  EXPECT_EQ(parse_study(base + "debrief: after-each-case\n", "s.yaml").debrief, DebriefWhen::AfterEachCase);
  EXPECT_EQ(parse_study(base + "debrief: at-end\n", "s.yaml").debrief, DebriefWhen::AtEnd);
  const std::string bad = error_of([&] { (void)parse_study(base + "debrief: sometimes\n", "s.yaml"); });
  EXPECT_NE(bad.find("s.yaml:15:10: debrief"), std::string::npos) << bad;
  EXPECT_NE(bad.find("after-each-case"), std::string::npos) << bad;
  const std::string boundary =
      error_of([&] { (void)parse_study("kind: boundary-shapes\nname: b\ndebrief: at-end\n", "b.yaml"); });
  EXPECT_NE(boundary.find("b.yaml:3:10: debrief: a boundary-shapes study has no debrief"), std::string::npos)
      << boundary;
  // The built-in diagnosis study debriefs after each case.
  EXPECT_EQ(load_study("diagnosis").debrief, DebriefWhen::AfterEachCase);
}

TEST(StudyDebrief, HitsMissesFalseMarksAndGradesInPlainWords) {
  TrialSetup setup;
  setup.kind = StudyKind::Diagnosis;
  setup.time_limit = 180.0;
  setup.truth.lesions = {{"46-occlusal", Grade::Severe, 2.2, 1.0, 2.0},
                         {"36-mesial", Grade::Mild, 1.8, 1.0, 0.9}};
  DiagnosisAnswers a;
  a.lesions = setup.truth.lesions;
  a.marks = {{{Vec3(1, 2, 3), Grade::Mild, 12.0, true}, 0, 0.1, true},      // found, graded wrong
             {{Vec3(1, 2, 3), Grade::Severe, 14.0, true}, 0, 0.0, false},   // on it again
             {{Vec3(9, 9, 9), Grade::Severe, 20.0, true}, -1, 3.2, false},  // false
             {{Vec3(1, 2, 9), Grade::Mild, 25.0, false}, -1, 6.0, false}};  // in the air
  a.ended_at = 61.0;
  const std::vector<Score> scores = {{"case_time", "", 61.0, "s"},
                                     {"soft_tissue_time", "", 0.3, "s"},
                                     {"soft_tissue_peak_force", "", 1.6, "N"},
                                     {"enamel_excess_force_time", "", 0.0, "s"},
                                     {"blocked_insertions", "", 2.0, "count"}};
  Recording rec;
  rec.soft_tissue_threshold = 1.0;
  rec.events = {{3.5, "penetration", "max_depth", 1.4, 0, 0.8},
                {4.0, "soft_tissue", "peak_force", 1.6, -1, 0.2}};
  const Debrief d = make_debrief(setup, a, scores, &rec, ScoringDesc{});

  ASSERT_EQ(d.lesions.size(), 2u);
  EXPECT_TRUE(d.lesions[0].found);
  EXPECT_FALSE(d.lesions[0].grade_right());
  EXPECT_EQ(d.lesions[0].found_at, 12.0);
  EXPECT_FALSE(d.lesions[1].found);
  ASSERT_EQ(d.marks.size(), 4u);
  EXPECT_EQ(d.marks[0].verdict, MarkVerdict::Found);
  EXPECT_EQ(d.marks[1].verdict, MarkVerdict::Again);
  EXPECT_EQ(d.marks[2].verdict, MarkVerdict::False);
  EXPECT_EQ(d.marks[3].verdict, MarkVerdict::InAir);
  ASSERT_EQ(d.insertions.size(), 1u);
  EXPECT_EQ(d.insertions[0].lesion, 1);
  EXPECT_EQ(d.insertions[0].depth, 1.4);
  const std::vector<std::string> expected = {
      "You found 1 of 2 lesions.",
      "Lesion 1 (46-occlusal, severe): found at 0:12, graded mild: wrong, it is severe.",
      "Lesion 2 (36-mesial, mild): missed, no mark on it.",
      "2 false marks where there is no lesion (1 made with the tool touching nothing).",
      "1 mark was on a lesion already found (only the first mark counts).",
      "Grades: 0 of the 1 lesion found graded right.",
      "You ended the case after 1:01.",
      "You pressed the gum or tongue harder than 1 N for 0.3 s (strongest 1.6 N): that hurts a patient.",
      "You never pushed too hard on healthy tooth.",
      "2 times the explorer pressed on caries without going in: tilt it so the tip, not the shank, leads.",
      "The explorer went into a lesion 1 time (listed below with their moments).",
  };
  EXPECT_EQ(d.lines, expected);
}

TEST(StudyDebrief, AHeadlessCaseDebriefsFromItsStoredAnswers) {
  const fs::path dir = test::scratch();
  RunOptions o;
  o.participant = "P01";
  o.database = dir / "class.db";
  StudyRun run(load_study((test::examples() / "diagnosis-small.yaml").string()), o);
  HeadlessOptions headless;
  headless.device = "scripted:" + (test::examples() / "probe-fossa.csv").string();
  const auto results = run_headless(run, load_answers(test::examples() / "diagnosis-answers.yaml"), headless);
  ASSERT_EQ(results.size(), 1u);
  const RebuiltTrial t = rebuild_trial(o.database);
  const Recording rec = load_recording(t.recording);
  const Debrief d = make_debrief(t.setup, t.answers, t.scores, &rec, t.study.scoring);
  ASSERT_EQ(d.lesions.size(), 1u);
  EXPECT_TRUE(d.lesions[0].found);
  EXPECT_TRUE(d.lesions[0].grade_right());
  ASSERT_EQ(d.marks.size(), 2u);
  EXPECT_EQ(d.marks[1].verdict, MarkVerdict::False);
  EXPECT_EQ(d.lines.front(), "You found 1 of 1 lesions: all of them.");
  // The same debrief from the answers the run returned.
  const Debrief live = make_debrief(run.setup(), parse_diagnosis_answers(results[0].answers_json, "answers"),
                                    results[0].scores, &rec, t.study.scoring);
  EXPECT_EQ(live.lines, d.lines);
}

}  // namespace
}  // namespace cariesim::training
