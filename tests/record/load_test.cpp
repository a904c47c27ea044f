// load_recording on files that are not (or not this version of) a recording.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/record/recorder.hpp"
#include "record/record_support.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;

void run_sql(const std::filesystem::path& file, const char* sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
  sqlite3_close(db);
}

std::string load_error(const std::filesystem::path& file) {
  try {
    load_recording(file);
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

TEST(LoadRecording, RejectsOtherDatabasesAndVersions) {
  test::ScratchDir dir("load");
  const auto other = dir / "other.db";
  run_sql(other, "CREATE TABLE patients (name TEXT);");
  EXPECT_THAT(load_error(other), HasSubstr("not a cariesim recording"));
  EXPECT_THAT(load_error(other), HasSubstr(other.string()));

  const auto future = dir / "future.db";
  run_sql(future,
          "PRAGMA application_id=1129468749;"  // "CRSM", a recording's
          "CREATE TABLE schema_version (version INTEGER, application TEXT);"
          "INSERT INTO schema_version VALUES (99, 'cariesim');");
  EXPECT_THAT(load_error(future), HasSubstr("schema version 99 is not supported"));

  EXPECT_THAT(load_error(dir / "absent.db"), HasSubstr("no such cariesim recording"));
  EXPECT_THAT(load_error(dir.path()), HasSubstr("is a folder, not a cariesim recording"));
}

TEST(LoadRecording, MissingSessionRowIsReported) {
  test::ScratchDir dir("load_session");
  const auto file = dir / "session.db";
  {
    Recorder recorder(file, test::synthetic_session(1000.0));
    recorder.stop();
  }
  run_sql(file, "DELETE FROM session;");
  EXPECT_THAT(load_error(file), HasSubstr("session row is missing"));
}

// A damaged file (here a samples page overwritten, as a .db copied without its -wal in the middle of
// a checkpoint can be) is refused naming the file, with what to do about it.
TEST(LoadRecording, ADamagedFileSaysHowToReadTheRecording) {
  test::ScratchDir dir("load_damaged");
  const auto file = dir / "damaged.db";
  constexpr double kRate = 1000.0;  // Hz
  {
    Recorder recorder(file, test::synthetic_session(kRate));
    recorder.start();
    for (std::size_t i = 0; i < 2000; ++i)
      ASSERT_TRUE(recorder.queue().push(test::synthetic_sample(i, kRate))) << "sample " << i;
    recorder.stop();
  }
  ASSERT_EQ(load_recording(file).samples.size(), 2000u);
  const auto bytes = std::filesystem::file_size(file);
  constexpr std::size_t kPage = 4096;  // bytes, SQLite's default page size
  ASSERT_GT(bytes, 8 * kPage);
  {
    std::fstream out(file, std::ios::in | std::ios::out | std::ios::binary);
    out.seekp(static_cast<std::streamoff>((bytes / kPage / 2) * kPage));
    const std::string garbage(kPage, '\xff');
    out.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  const std::string error = load_error(file);
  EXPECT_THAT(error, HasSubstr(file.string()));
  EXPECT_THAT(error, HasSubstr("malformed"));
  EXPECT_THAT(error, HasSubstr("copied without its -wal"));
}

}  // namespace
}  // namespace cariesim
