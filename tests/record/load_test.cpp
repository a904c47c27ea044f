// load_recording on files that are not (or not this version of) a recording.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

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
          "CREATE TABLE schema_version (version INTEGER, application TEXT);"
          "INSERT INTO schema_version VALUES (99, 'cariesim');");
  EXPECT_THAT(load_error(future), HasSubstr("schema version 99 is not supported"));

  EXPECT_THAT(load_error(dir / "absent.db"), HasSubstr("no such recording"));
  EXPECT_THAT(load_error(dir.path()), HasSubstr("is a directory"));
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

}  // namespace
}  // namespace cariesim
