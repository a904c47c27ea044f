// StudyRun and the study database (src/training/run.cpp): rows, transactions, answer checks, and a
// run killed with SIGKILL in the middle of a trial.
#include "cariesim/training/run.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "cariesim/common/error.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/training/headless.hpp"
#include "training/study_schema.hpp"
#include "training/training_support.hpp"

extern char** environ;

namespace cariesim::training {
namespace {

namespace fs = std::filesystem;

Study boundary_small() { return load_study((test::examples() / "boundary-small.yaml").string()); }

RunOptions options(const fs::path& db, const std::string& participant = "P01") {
  RunOptions o;
  o.participant = participant;
  o.station = "station-1";
  o.database = db;
  return o;
}

TEST(StudyRun, WritesTheSchemaAndOneRowPerTrialWithItsScores) {
  const fs::path db = test::scratch() / "class.db";
  StudyRun run(boundary_small(), options(db));
  EXPECT_EQ(run.trial_count(), 2);
  EXPECT_EQ(run.seed(), 42u);
  for (int i = 0; i < 2; ++i) {
    const TrialSetup& t = run.begin_trial();
    // Trial 1 all right, trial 2 with the first two cubes swapped.
    std::vector<std::string> named = t.truth.shapes;
    if (i == 1) std::swap(named[0], named[1]);
    for (int c = 0; c < 3; ++c) run.name_shape(c, named[static_cast<std::size_t>(c)]);
    const TrialResult r = run.end_trial("");
    EXPECT_EQ(r.index, i);
    EXPECT_EQ(r.seed, trial_seed(participant_seed(42, "P01"), i));
  }
  EXPECT_TRUE(run.finished());

  // The schema: application id, version row, and the rows as written.
  EXPECT_EQ(test::query(db, "PRAGMA application_id")[0][0], std::to_string(kStudyApplicationId));
  const auto version = test::query(db, "SELECT version, application FROM schema_version");
  ASSERT_EQ(version.size(), 1u);
  EXPECT_EQ(version[0],
            (std::vector<std::string>{std::to_string(kStudySchemaVersion), std::string(kStudyApplication)}));
  const auto trials =
      test::query(db,
                  "SELECT station, participant, study, kind, trial, seed, ended_at IS NOT NULL,"
                  " recording FROM trials ORDER BY id");
  ASSERT_EQ(trials.size(), 2u);
  EXPECT_EQ(trials[0], (std::vector<std::string>{"station-1", "P01", "boundary-small", "boundary-shapes", "1",
                                                 std::to_string(trial_seed(participant_seed(42, "P01"), 0)),
                                                 "1", "NULL"}));
  EXPECT_EQ(trials[1][4], "2");
  const auto points = test::query(
      db, "SELECT trial_id, value, unit FROM scores WHERE name = 'boundary_point' ORDER BY trial_id");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0][1], "1.0");
  EXPECT_EQ(points[1][1], "0.0");
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM scores WHERE name = 'shape_correct' AND value = 0")[0][0],
            "2");
  // The JSON columns carry the same.
  const auto json = test::query(db, "SELECT answers, scores FROM trials WHERE trial = 2");
  EXPECT_NE(json[0][0].find("\"hidden\""), std::string::npos) << json[0][0];
  EXPECT_NE(json[0][1].find("\"boundary_point\":0"), std::string::npos) << json[0][1];
}

TEST(StudyRun, ATrialsRowIsCommittedWhenItBeginsWithEndedAtNull) {
  const fs::path db = test::scratch() / "class.db";
  StudyRun run(boundary_small(), options(db));
  run.begin_trial();
  const auto rows = test::query(db, "SELECT ended_at, recording, answers, scores FROM trials");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0][0], "NULL");
  EXPECT_EQ(rows[0][1], "class-recordings/boundary-small-P01-1.db");
  EXPECT_EQ(run.recording_path(), (db.parent_path() / "class-recordings" / "boundary-small-P01-1.db"));
  EXPECT_TRUE(fs::is_directory(run.recording_path().parent_path()));
  // A recording left under the next row's name (a deleted database's) is not overwritten.
  std::ofstream(db.parent_path() / "class-recordings" / "boundary-small-P01-2.db") << "left over";
  // Abandoned: the row stays open and the next trial gets its own row.
  run.abandon_trial();
  run.begin_trial();
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM trials WHERE ended_at IS NULL")[0][0], "2");
  EXPECT_EQ(run.recording_path().filename(), "boundary-small-P01-2-2.db");
}

// One study seed (the example's `seed: 42`): a participant's trials come from their own seed, so two
// participants get different trials and the same participant again gets the same; with same_cases
// (a course's exam_seed) everyone gets the trials of the study seed itself.
TEST(StudyRun, AppendsToADatabaseAndEachParticipantGetsTrialsOfTheirOwn) {
  const fs::path dir = test::scratch();
  for (const bool same : {false, true}) {
    const fs::path db = dir / (same ? "exam.db" : "class.db");
    for (const std::string participant : {"P01", "P02", "P01"}) {
      RunOptions o = options(db, participant);
      o.same_cases = same;
      StudyRun run(boundary_small(), o);
      while (!run.finished()) {
        const TrialSetup& t = run.begin_trial();
        EXPECT_EQ(t.seed, run.seed_of_trial(t.index));
        for (int c = 0; c < 3; ++c) run.name_shape(c, t.truth.shapes[static_cast<std::size_t>(c)]);
        run.end_trial("");
      }
    }
    const auto rows = test::query(db, "SELECT participant, trial, seed, answers FROM trials ORDER BY id");
    ASSERT_EQ(rows.size(), 6u);
    EXPECT_EQ(rows[2][0], "P02");
    EXPECT_EQ(rows[0][2], rows[4][2]);  // P01 twice: the same trials
    EXPECT_EQ(rows[1][3], rows[5][3]);
    EXPECT_NE(rows[0][2], rows[1][2]);
    if (same) {
      EXPECT_EQ(rows[0][2], std::to_string(trial_seed(42, 0)));
      EXPECT_EQ(rows[2][2], rows[0][2]);
      EXPECT_EQ(rows[3][3], rows[1][3]);
    } else {
      EXPECT_EQ(rows[0][2], std::to_string(trial_seed(participant_seed(42, "P01"), 0)));
      EXPECT_EQ(rows[2][2], std::to_string(trial_seed(participant_seed(42, "P02"), 0)));
      EXPECT_NE(rows[2][2], rows[0][2]);
    }
  }
}

TEST(StudyRun, RefusesWhatIsNotAStudyDatabase) {
  const fs::path dir = test::scratch();
  // A session recording is a SQLite file of another application.
  {
    Recorder recorder(dir / "session.db", SessionInfo{});
    recorder.start();
    recorder.stop();
  }
  try {
    StudyRun run(boundary_small(), options(dir / "session.db"));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "not a study database (application id \"CRSM\", a cariesim session recording"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(StudyRun(boundary_small(), options(dir / "missing-folder" / "x.db")), Error);
  EXPECT_THROW(StudyRun(boundary_small(), options(dir / "x.db", "")), Error);
  EXPECT_THROW(StudyRun(boundary_small(), options(dir / "x.db", "P 01")), Error);
}

// The names a recording's file name is built from are checked with the station-name rule, also for a
// Study made in code (a study file's name is checked when it is read): nothing else reaches a path.
TEST(StudyRun, BuildsPathsFromValidNamesOnly) {
  const fs::path dir = test::scratch();
  for (const std::string name : {"../../../../tmp/x", "/tmp/x", "..", "a b", ""}) {
    Study study = boundary_small();
    study.name = name;
    try {
      StudyRun run(study, options(dir / "x.db"));
      ADD_FAILURE() << "study name '" << name << "' was taken";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("study"), std::string::npos) << e.what();
    }
  }
  for (const std::string& participant :
       std::vector<std::string>{"../P01", ".P01", "P/01", std::string(65, 'p')})
    EXPECT_THROW(StudyRun(boundary_small(), options(dir / "x.db", participant)), Error) << participant;
}

// A new study database is the owner's only (0600, its -wal and -shm too), and so is a new recordings
// folder (0700): the rows hold each trial's case once it ended. Before, both took the umask's modes
// (0644, 0755).
TEST(StudyRun, NewDatabasesAndRecordingFoldersAreOwnerOnly) {
  const fs::path dir = test::scratch();
  const fs::path db = dir / "class.db";
  StudyRun run(boundary_small(), options(db));
  run.begin_trial();
  constexpr fs::perms kOthers = fs::perms::group_all | fs::perms::others_all;
  EXPECT_EQ(fs::status(db).permissions() & kOthers, fs::perms::none);
  for (const char* suffix : {"-wal", "-shm"}) {
    if (fs::exists(db.string() + suffix)) {
      EXPECT_EQ(fs::status(db.string() + suffix).permissions() & kOthers, fs::perms::none) << suffix;
    }
  }
  EXPECT_EQ(fs::status(run.recording_path().parent_path()).permissions() & kOthers, fs::perms::none);
  // create_study_folder: a new folder (and parents) 0700, an existing one as it is.
  create_study_folder(dir / "records" / "a");
  EXPECT_EQ(fs::status(dir / "records" / "a").permissions() & kOthers, fs::perms::none);
  fs::create_directory(dir / "shared");
  fs::permissions(dir / "shared", fs::perms::owner_all | fs::perms::group_all);
  create_study_folder(dir / "shared");
  EXPECT_EQ(fs::status(dir / "shared").permissions() & fs::perms::group_all, fs::perms::group_all);
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(create_study_folder(dir / "file"), Error);
}

// Trainee mode: while a trial runs its row holds no seed (the seed rebuilds the case: site,
// severity, size, depth), so a trainee who reads the station's database learns nothing of it; the
// seed is written when the trial ends, or is abandoned (with the reason, which may name lesions).
TEST(StudyRun, InTraineeModeTheSeedIsWrittenOnlyWhenTheTrialEnds) {
  const fs::path db = test::scratch() / "class.db";
  RunOptions o = options(db);
  o.hide_case_while_running = true;
  StudyRun run(boundary_small(), o);
  const TrialSetup& t = run.begin_trial();
  EXPECT_EQ(test::query(db, "SELECT seed FROM trials")[0][0], std::to_string(kSeedNotWritten));
  for (int c = 0; c < 3; ++c) run.name_shape(c, t.truth.shapes[static_cast<std::size_t>(c)]);
  (void)run.end_trial("");
  EXPECT_EQ(test::query(db, "SELECT seed FROM trials WHERE trial = 1")[0][0],
            std::to_string(trial_seed(participant_seed(42, "P01"), 0)));
  run.begin_trial();
  EXPECT_EQ(test::query(db, "SELECT seed FROM trials WHERE trial = 2")[0][0],
            std::to_string(kSeedNotWritten));
  run.abandon_trial("lesion1 misses tooth46");
  const auto row = test::query(db, "SELECT seed, answers, ended_at FROM trials WHERE trial = 2");
  EXPECT_EQ(row[0], (std::vector<std::string>{std::to_string(trial_seed(participant_seed(42, "P01"), 1)),
                                              R"({"error":"lesion1 misses tooth46"})", "NULL"}));
}

TEST(StudyRun, ChecksTheAnswers) {
  const fs::path dir = test::scratch();
  {
    StudyRun run(boundary_small(), options(dir / "b.db"));
    EXPECT_THROW(run.name_shape(0, "square"), Error);  // no trial begun
    run.begin_trial();
    EXPECT_THROW(run.name_shape(3, "square"), Error);
    EXPECT_THROW(run.name_shape(0, "hexagon"), Error);
    EXPECT_THROW(run.mark(Vec3::Zero(), Grade::Mild, 1.0), Error);  // not a diagnosis trial
    EXPECT_THROW(run.begin_trial(), Error);
  }
  Study tuning = load_study((test::examples() / "tuning-small.yaml").string());
  StudyRun run(tuning, options(dir / "t.db"));
  const TrialSetup& t = run.begin_trial();
  ASSERT_EQ(run.current_level(), t.levels[0]);
  EXPECT_THROW(run.confirm_tuning({{"mu_s", 0.2}}, 1.0), Error);                 // mu_d missing
  EXPECT_THROW(run.confirm_tuning({{"mu_s", 0.2}, {"mu_d", 1.5}}, 1.0), Error);  // beyond its slider
  EXPECT_THROW(run.confirm_tuning({{"mu_s", 0.2}, {"mu_d", NAN}}, 1.0), Error);
  EXPECT_THROW(run.confirm_tuning({{"mu_s", 0.2}, {"mu_d", 0.1}, {"k_c", 1.0}}, 1.0), Error);
  run.confirm_tuning({{"mu_s", 0.2}, {"mu_d", 0.1}}, 1.0);
  ASSERT_EQ(run.current_level(), t.levels[1]);
  // Ending with a level unconfirmed fails and leaves the trial open (row and all).
  EXPECT_THROW(run.end_trial(""), Error);
  EXPECT_TRUE(run.in_trial());
  EXPECT_EQ(test::query(dir / "t.db", "SELECT ended_at FROM trials")[0][0], "NULL");
  run.confirm_tuning({{"mu_s", 0.6}, {"mu_d", 0.5}}, 2.0);
  EXPECT_FALSE(run.current_level().has_value());
  const TrialResult r = run.end_trial("");
  EXPECT_EQ(r.scores.size(), 4u);
  EXPECT_EQ(test::query(dir / "t.db", "SELECT count(*) FROM trials WHERE ended_at IS NOT NULL")[0][0], "1");
}

// The child of StudyRunCrash: runs boundary-small headless into $CARIESIM_STUDY_CHILD_DB, its first
// trial 0.2 s long and its second 60 s, and is killed during the second.
TEST(StudyRunCrash, DISABLED_ChildRunsUntilKilled) {
  const char* db = std::getenv("CARIESIM_STUDY_CHILD_DB");
  ASSERT_NE(db, nullptr);
  StudyRun run(boundary_small(), options(db));
  const ScriptedAnswers answers = parse_answers(
      "trials:\n  - {shapes: [square, circle, triangle], end: 0.2}\n  - {shapes: [square, circle, "
      "triangle]}\n",
      "child.yaml");
  HeadlessOptions headless;
  headless.duration = 60.0;
  run_headless(run, answers, headless);
}

TEST(StudyRunCrash, AKilledRunKeepsItsEndedTrialsAndLeavesTheOpenOneNull) {
  const fs::path dir = test::scratch();
  const fs::path db = dir / "class.db";
  // Spawn this executable running only the child test, with the database in its environment.
  const std::string env_db = "CARIESIM_STUDY_CHILD_DB=" + db.string();
  std::vector<std::string> env_strings = {env_db};
  for (char** e = environ; *e != nullptr; ++e) env_strings.emplace_back(*e);
  std::vector<char*> envp;
  for (std::string& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string exe = "/proc/self/exe";
  std::string filter = "--gtest_filter=StudyRunCrash.DISABLED_ChildRunsUntilKilled";
  std::string disabled = "--gtest_also_run_disabled_tests";
  std::vector<char*> argv = {exe.data(), filter.data(), disabled.data(), nullptr};
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv.data(), envp.data()), 0);

  // Wait until trial 1 has ended and trial 2 has recorded a while, then SIGKILL.
  bool second_running = false;
  for (int i = 0; i < 600 && !second_running; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (!fs::exists(db) || !fs::exists(dir / "class-recordings" / "boundary-small-P01-2.db")) continue;
    second_running = true;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(second_running) << "the child never reached its second trial";
  ASSERT_TRUE(WIFSIGNALED(status)) << "the child ended on its own";

  // Trial 1 whole, trial 2 open; trial 2's recording readable up to the kill.
  const auto rows = test::query(db, "SELECT trial, ended_at IS NULL, recording FROM trials ORDER BY id");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0][1], "0");
  EXPECT_EQ(rows[1][1], "1");
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM scores WHERE trial_id = 1")[0][0], "4");
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM scores WHERE trial_id = 2")[0][0], "0");
  const Recording rec = load_recording(dir / rows[1][2]);
  EXPECT_GT(rec.samples.size(), 100u);
  // The database takes the next run.
  StudyRun again(boundary_small(), options(db, "P02"));
  again.begin_trial();
  EXPECT_EQ(test::query(db, "SELECT count(*) FROM trials")[0][0], "3");
}

}  // namespace
}  // namespace cariesim::training
