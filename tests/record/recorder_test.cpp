// The recorder: file creation rules, WAL mode and schema, batching, the writer's error path (a size
// limit standing in for a full disk), events from other threads, and commits while the servo pauses.
#include "cariesim/record/recorder.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <thread>
#include <vector>

#include "cariesim/common/error.hpp"
#include "record/record_support.hpp"

namespace cariesim {
namespace {

using test::synthetic_sample;
using test::synthetic_session;
using ::testing::HasSubstr;

// Pushes samples [first, first + count) of the synthetic stream; false when the queue was full.
bool push_range(Recorder& recorder, std::size_t first, std::size_t count, double rate_hz) {
  for (std::size_t i = first; i < first + count; ++i)
    if (!recorder.queue().push(synthetic_sample(i, rate_hz))) return false;
  return true;
}

// One text value from a query on the file, through SQLite directly.
std::string query_text(const std::filesystem::path& file, const std::string& sql) {
  sqlite3* db = nullptr;
  std::string out = "<error>";
  if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr) == SQLITE_OK &&
        sqlite3_step(stmt) == SQLITE_ROW) {
      const auto* text = sqlite3_column_text(stmt, 0);
      out = text ? reinterpret_cast<const char*>(text) : "<null>";
    }
    sqlite3_finalize(stmt);
  }
  sqlite3_close(db);
  return out;
}

TEST(Recorder, WritesWalDatabaseWithVersionedSchema) {
  test::ScratchDir dir("schema");
  const auto file = dir / "session.db";
  {
    Recorder recorder(file, synthetic_session(1000.0));
    ASSERT_TRUE(push_range(recorder, 0, 100, 1000.0));
    recorder.start();
    recorder.stop();
    EXPECT_EQ(recorder.written(), 100u);
  }
  EXPECT_EQ(query_text(file, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(query_text(file, "SELECT version FROM schema_version"), "1");
  EXPECT_EQ(query_text(file, "SELECT application FROM schema_version"), "cariesim");
  EXPECT_EQ(query_text(file, "SELECT scene_hash FROM session"), "fedcba9876543210");
  EXPECT_EQ(query_text(file, "SELECT count(*) FROM samples"), "100");
  EXPECT_EQ(query_text(file, "SELECT max(id) FROM samples"), "99");
  EXPECT_EQ(query_text(file, "SELECT name FROM state_names WHERE code = 2"), "inserting");
  EXPECT_NE(query_text(file, "SELECT ended_at FROM session"), "<null>");
  // stop() checkpointed: the WAL is empty.
  const std::filesystem::path wal = file.string() + "-wal";
  EXPECT_TRUE(!std::filesystem::exists(wal) || std::filesystem::file_size(wal) == 0);
}

// The WAL is checkpointed into the database file as the recording goes (every 250 ms of sample or
// wall time) and its file is bounded, so the .db alone holds the stream and an hour stays under the
// size docs/records.md states (a -wal file holding everything until stop() would be 7 MB here,
// 1.2 GB per hour, beside a .db of 4 KB).
TEST(Recorder, CheckpointsAsItGoesAndBoundsTheWal) {
  test::ScratchDir dir("wal_bound");
  const auto file = dir / "session.db";
  const std::filesystem::path wal = file.string() + "-wal";
  constexpr double kRate = 1000.0;              // Hz
  constexpr std::size_t kSamples = 30000;       // 30 s of samples
  constexpr uintmax_t kMaxWalBytes = 4u << 20;  // bytes, the documented bound
  constexpr double kMaxBytesPerHour = 1.0e9;    // bytes per hour at 1 kHz, docs/records.md
  Recorder recorder(file, synthetic_session(kRate));
  recorder.start();
  uintmax_t max_wal = 0;
  std::error_code ec;
  for (std::size_t i = 0; i < kSamples; ++i) {
    while (!recorder.queue().push(synthetic_sample(i, kRate))) std::this_thread::yield();
    if (i % 500 == 0) max_wal = std::max(max_wal, std::filesystem::file_size(wal, ec));
  }
  while (recorder.written() < kSamples && recorder.status().ok) {
    max_wal = std::max(max_wal, std::filesystem::file_size(wal, ec));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(recorder.status().ok) << recorder.status().message;
  EXPECT_LE(max_wal, kMaxWalBytes) << "the WAL grew with the recording";

  // The database file alone (what a copy of the .db without its -wal holds) has all but the last
  // second: the checkpoint of the last commit has run when written() counts it.
  const auto copy = dir / "copy.db";
  std::filesystem::copy_file(file, copy);
  const Recording alone = load_recording(copy);
  EXPECT_GE(alone.samples.size() + static_cast<std::size_t>(kRate), kSamples);
  EXPECT_GT(recorder.status().checkpoints, 0u);

  recorder.stop();
  const double bytes_per_sample =
      static_cast<double>(std::filesystem::file_size(file)) / static_cast<double>(kSamples);
  EXPECT_LE(bytes_per_sample * kRate * 3600.0, kMaxBytesPerHour) << bytes_per_sample << " bytes per sample";
  RecordProperty("bytes_per_sample", std::to_string(bytes_per_sample));
  RecordProperty("max_wal_bytes", std::to_string(max_wal));
}

TEST(Recorder, RefusesToOverwriteUnlessAsked) {
  test::ScratchDir dir("overwrite");
  const auto file = dir / "session.db";
  std::ofstream(file) << "precious";
  try {
    Recorder recorder(file, synthetic_session(1000.0));
    FAIL() << "an existing file was overwritten";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("already exists"));
    EXPECT_THAT(e.what(), HasSubstr(file.string()));
  }
  std::ifstream in(file);
  std::string kept;
  in >> kept;
  EXPECT_EQ(kept, "precious");

  RecorderOptions options;
  options.overwrite = true;
  {
    Recorder recorder(file, synthetic_session(1000.0), options);
    ASSERT_TRUE(push_range(recorder, 0, 10, 1000.0));
    recorder.start();
    recorder.stop();
  }
  EXPECT_EQ(load_recording(file).samples.size(), 10u);
}

TEST(Recorder, UnwritablePathsAndBadOptionsThrowNamingTheFile) {
  test::ScratchDir dir("unwritable");
  const auto missing = dir / "no_such_folder" / "session.db";
  try {
    Recorder recorder(missing, synthetic_session(1000.0));
    FAIL() << "created a file in a missing folder";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(missing.string()));
    EXPECT_THAT(e.what(), HasSubstr("cannot create"));
  }
  EXPECT_THROW(Recorder(dir.path(), synthetic_session(1000.0)), Error);

  RecorderOptions options;
  options.batch_seconds = 0.2;  // beyond the 100 ms loss budget
  EXPECT_THROW(Recorder(dir / "a.db", synthetic_session(1000.0), options), Error);
  options = {};
  options.soft_tissue_threshold = -1.0;
  EXPECT_THROW(Recorder(dir / "b.db", synthetic_session(1000.0), options), Error);
  SessionInfo info = synthetic_session(0.0);
  EXPECT_THROW(Recorder(dir / "c.db", info), Error);
  // Refused arguments leave no file behind.
  EXPECT_FALSE(std::filesystem::exists(dir / "a.db"));
  EXPECT_FALSE(std::filesystem::exists(dir / "c.db"));
}

// Samples all queued before start: the writer cuts them into windows of batch_seconds of sample
// time, so at 1 kHz and 50 ms no batch holds more than 50 samples.
TEST(Recorder, BatchesCoverAtMostBatchSecondsOfSampleTime) {
  test::ScratchDir dir("batches");
  for (const double rate : {1000.0, 10000.0}) {
    const auto file = dir / ("batches_" + std::to_string(static_cast<int>(rate)) + ".db");
    RecorderOptions options;
    options.batch_seconds = 0.05;
    Recorder recorder(file, synthetic_session(rate), options);
    const auto count = static_cast<std::size_t>(rate);  // one second
    ASSERT_TRUE(push_range(recorder, 0, count, rate));
    recorder.start();
    recorder.stop();
    const RecorderStatus status = recorder.status();
    EXPECT_TRUE(status.ok) << status.message;
    EXPECT_EQ(status.written, count);
    EXPECT_EQ(recorder.written(), count);
    EXPECT_EQ(status.discarded, 0u);
    const auto window = static_cast<uint64_t>(std::llround(options.batch_seconds * rate));
    EXPECT_LE(status.max_batch_samples, window) << rate;
    EXPECT_GE(status.batches, count / window) << rate;
    EXPECT_EQ(load_recording(file).samples.size(), count);
  }
}

// A size limit makes SQLite answer "full" as a full disk would: the writer reports it, keeps draining
// (the servo never sees a full queue), and the committed prefix stays readable and continuous.
TEST(Recorder, FullDatabaseIsReportedAndTheServoSideKeepsRunning) {
  test::ScratchDir dir("full");
  const auto file = dir / "full.db";
  RecorderOptions options;
  options.max_bytes = 256 * 1024;
  options.queue_capacity = 1000;
  Recorder recorder(file, synthetic_session(1000.0), options);
  recorder.start();
  const std::size_t total = 20000;  // ~ 5 MB of rows, far beyond the limit
  std::size_t refused = 0;
  for (std::size_t i = 0; i < total; ++i) {
    while (!recorder.queue().push(synthetic_sample(i, 1000.0))) {
      ++refused;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  recorder.stop();
  const RecorderStatus status = recorder.status();
  EXPECT_FALSE(status.ok);
  EXPECT_THAT(status.message, HasSubstr(file.string()));
  EXPECT_THAT(status.message, HasSubstr("full"));
  EXPECT_GT(status.written, 0u);
  EXPECT_LT(status.written, total);
  EXPECT_EQ(status.written + status.discarded, total);

  const Recording recording = load_recording(file);
  ASSERT_EQ(recording.samples.size(), status.written);
  for (std::size_t i = 0; i < recording.samples.size(); ++i)
    ASSERT_EQ(recording.samples[i].t, synthetic_sample(i, 1000.0).t) << i;
  EXPECT_TRUE(recording.info.ended_at.empty()) << "a failed recording is not marked complete";
}

// A paused servo (no new samples) still gets its last samples committed by the wall-clock rule.
TEST(Recorder, CommitsWhileTheStreamPauses) {
  test::ScratchDir dir("pause");
  Recorder recorder(dir / "pause.db", synthetic_session(1000.0));
  recorder.start();
  ASSERT_TRUE(push_range(recorder, 0, 7, 1000.0));
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (recorder.written() < 7 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(recorder.written(), 7u);
  EXPECT_EQ(load_recording(dir / "pause.db").samples.size(), 7u) << "readable while recording";
  recorder.stop();
}

TEST(Recorder, EventsFromTheUiThreadAreWritten) {
  test::ScratchDir dir("ui_events");
  const auto file = dir / "ui.db";
  {
    Recorder recorder(file, synthetic_session(1000.0));
    recorder.start();
    std::thread ui([&recorder] { recorder.record_event({0.25, "param", "lesion1 mu_s", 0.42, 0, 0.0}); });
    ui.join();
    ASSERT_TRUE(push_range(recorder, 0, 10, 1000.0));
    recorder.stop();
    EXPECT_EQ(recorder.status().events, load_recording(file).events.size());
  }
  const Recording recording = load_recording(file);
  const auto it = std::find_if(recording.events.begin(), recording.events.end(),
                               [](const RecordedEvent& e) { return e.kind == "param"; });
  ASSERT_NE(it, recording.events.end());
  EXPECT_EQ(it->detail, "lesion1 mu_s");
  EXPECT_EQ(it->value, 0.42);
  EXPECT_EQ(it->lesion, 0);
  EXPECT_EQ(it->t, 0.25);
}

// Trainee mode keeps a trial's recording in memory (RecorderOptions::hold_until_stop): while it runs
// the file is claimed but empty and owner-only, with no -wal beside it, so nothing at the station reads
// the session's lesion parameters or the samples' `lesion` column off it; stop() writes it whole.
// Before, every recording was on disk from its first batch (its session row at once).
TEST(Recorder, AHeldRecordingReachesTheDiskOnlyWhenItStops) {
  test::ScratchDir dir("held");
  const auto file = dir / "held.db";
  RecorderOptions options;
  options.hold_until_stop = true;
  Recorder recorder(file, synthetic_session(1000.0), options);
  recorder.start();
  ASSERT_TRUE(push_range(recorder, 0, 500, 1000.0));
  recorder.record_event({0.25, "param", "mu_s", 0.42, 0, 0.0});
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (recorder.written() < 500 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(recorder.written(), 500u) << "the batches were committed (in memory)";
  EXPECT_EQ(std::filesystem::file_size(file), 0u) << "nothing of the session on disk while it runs";
  EXPECT_FALSE(std::filesystem::exists(file.string() + "-wal"));
  EXPECT_EQ(std::filesystem::status(file).permissions() &
                (std::filesystem::perms::group_all | std::filesystem::perms::others_all),
            std::filesystem::perms::none)
      << "owner-only";
  EXPECT_THROW((void)load_recording(file), Error);
  recorder.stop();
  EXPECT_TRUE(recorder.status().ok) << recorder.status().message;

  const Recording recording = load_recording(file);
  ASSERT_EQ(recording.samples.size(), 500u);
  for (std::size_t i = 0; i < recording.samples.size(); ++i)
    ASSERT_EQ(recording.samples[i].t, synthetic_sample(i, 1000.0).t) << i;
  EXPECT_EQ(recording.info.parameters, synthetic_session(1000.0).parameters);
  EXPECT_FALSE(recording.info.ended_at.empty());
  EXPECT_EQ(std::count_if(recording.events.begin(), recording.events.end(),
                          [](const RecordedEvent& e) { return e.kind == "param"; }),
            1);
}

// Held recordings one after another in the same working folder: each is its own memory database
// and none leaves a file there. Before, the memory database was a file named ":memory:" in the
// working folder, so the second trial failed ("table schema_version already exists") and the first
// trial's samples sat on the station's disk.
TEST(Recorder, HeldRecordingsLeaveNothingInTheWorkingFolder) {
  test::ScratchDir dir("held-twice");
  const std::filesystem::path before = std::filesystem::current_path();
  std::filesystem::current_path(dir.path());
  for (const char* name : {"first.db", "second.db"}) {
    RecorderOptions options;
    options.hold_until_stop = true;
    Recorder recorder(dir / name, synthetic_session(1000.0), options);
    recorder.start();
    ASSERT_TRUE(push_range(recorder, 0, 50, 1000.0));
    recorder.stop();
    EXPECT_TRUE(recorder.status().ok) << name << ": " << recorder.status().message;
    EXPECT_EQ(load_recording(dir / name).samples.size(), 50u) << name;
  }
  std::filesystem::current_path(before);
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"first.db", "second.db"}));
}

TEST(Recorder, StopIsIdempotentAndWorksWithoutStart) {
  test::ScratchDir dir("stop");
  Recorder recorder(dir / "stop.db", synthetic_session(1000.0));
  ASSERT_TRUE(push_range(recorder, 0, 3, 1000.0));
  recorder.stop();
  recorder.stop();
  EXPECT_EQ(recorder.written(), 3u);
  EXPECT_FALSE(load_recording(dir / "stop.db").info.ended_at.empty());
}

}  // namespace
}  // namespace cariesim
