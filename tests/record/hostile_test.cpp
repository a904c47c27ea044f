// A recording from elsewhere runs none of its own SQL: one whose `samples` is a recursive view (a
// 20 KB file that made load_recording spin forever, export fill the disk with temporary files and
// `--device replay:` hang) is refused at once, naming the view, by every reader.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <functional>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/record/replay.hpp"
#include "record/record_support.hpp"
#include "support/deadline.hpp"
#include "support/raw_sql.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// s: far more than a refusal takes; on a reader that runs the view, the call never ends.
constexpr double kDeadline = 10.0;

using test::run_sql;

// The generator: a real recording whose samples table is replaced by a view over an endless
// recursive query with every sample column (ordering it by id sorts without end into temporary files).
fs::path recursive_samples_recording(const fs::path& file) {
  {
    Recorder recorder(file, test::synthetic_session(1000.0));
    for (std::size_t i = 0; i < 10; ++i)
      EXPECT_TRUE(recorder.queue().push(test::synthetic_sample(i, 1000.0)));
    recorder.start();
    recorder.stop();
  }
  std::string columns;
  for (const char* c : {"h_px",       "h_py",
                        "h_pz",       "h_qw",
                        "h_qx",       "h_qy",
                        "h_qz",       "g_px",
                        "g_py",       "g_pz",
                        "g_qw",       "g_qx",
                        "g_qy",       "g_qz",
                        "fx",         "fy",
                        "fz",         "tx",
                        "ty",         "tz",
                        "state",      "depth",
                        "contacts",   "step_us",
                        "lesion",     "soft_tissue_force",
                        "step_flags", "safety_flags",
                        "overrun",    "buttons"})
    columns += std::string(", randomblob(64) AS ") + c;
  run_sql(file,
          "PRAGMA journal_mode=DELETE; DROP TABLE samples; CREATE VIEW samples AS WITH RECURSIVE r(i) AS "
          "(SELECT 0 UNION ALL SELECT i + 1 FROM r) SELECT i AS id, i * 0.001 AS t" +
              columns + " FROM r;");
  return file;
}

TEST(HostileRecording, ARecursiveViewIsRefusedByEveryReader) {
  test::ScratchDir dir("hostile_view");
  const fs::path file = recursive_samples_recording(dir / "crafted.db");
  EXPECT_LT(fs::file_size(file), 64u * 1024u) << "a small file";
  const struct {
    const char* reader;
    std::function<void()> call;
  } readers[] = {
      {"load_recording", [&] { load_recording(file); }},
      {"export_recording_csv", [&] { export_recording_csv(file, dir / "export"); }},
      {"make_replay_device", [&] { make_replay_device(file, false); }},
  };
  for (const auto& r : readers) {
    const test::DeadlineResult result = test::run_with_deadline(r.call, kDeadline);
    EXPECT_TRUE(result.finished) << r.reader << ": " << result.message;
    EXPECT_TRUE(result.threw) << r.reader;
    EXPECT_THAT(result.message, HasSubstr(file.string() + ": refused: its 'samples' is a view")) << r.reader;
    EXPECT_LT(result.seconds, 5.0) << r.reader;
  }
  EXPECT_FALSE(fs::exists(dir / "export")) << "nothing exported";
}

// A trigger or an extra table in a recording is refused the same way, naming it.
TEST(HostileRecording, TriggersAndForeignObjectsAreRefusedByName) {
  test::ScratchDir dir("hostile_objects");
  const fs::path file = dir / "trigger.db";
  {
    Recorder recorder(file, test::synthetic_session(1000.0));
    recorder.stop();
  }
  run_sql(file, "CREATE TRIGGER keep AFTER INSERT ON events BEGIN DELETE FROM samples; END;");
  try {
    load_recording(file);
    FAIL() << "a recording with a trigger was read";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("it holds a trigger 'keep' on 'events'"));
  }
}

}  // namespace
}  // namespace cariesim
