// io/sqlite.hpp: a database from elsewhere runs none of its own SQL, holds exactly its schema, cannot
// make a query spin or fill the disk, is read without a file made beside it (also on a read-only
// medium), and a lock is named as a lock.
#include "cariesim/io/sqlite.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "cariesim/common/error.hpp"
#include "support/raw_sql.hpp"

namespace cariesim::io {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr std::int32_t kTestId = 0x54455354;  // "TEST"

// A schema of a small kind of database: a version table, a table of items and an index on it.
Schema test_schema() {
  Schema s;
  s.what = "test database";
  s.application_id = kTestId;
  s.known_applications = {{0x4352534d, "a cariesim session recording"}};
  s.version_table = "version";
  s.identify = [](Database& db) {
    Statement v(db, "SELECT v FROM version");
    if (v.step() != SQLITE_ROW || v.integer(0) != 1)
      throw Error(db.file() + ": not a test database (version)");
  };
  s.objects = {{SchemaObject::Type::Table, "version", "version", {"v"}},
               {SchemaObject::Type::Table, "items", "items", {"id", "value"}},
               {SchemaObject::Type::Index, "items_by_value", "items", {}}};
  return s;
}

// The SQL that builds a valid test database, before anything crafted is added.
constexpr const char* kValidSql =
    "PRAGMA application_id=1413829460;"  // 0x54455354
    "CREATE TABLE version (v INTEGER NOT NULL); INSERT INTO version VALUES (1);"
    "CREATE TABLE items (id INTEGER PRIMARY KEY, value REAL NOT NULL);"
    "CREATE INDEX items_by_value ON items (value);"
    "INSERT INTO items (value) VALUES (1.5), (2.5);";

using test::run_sql;

std::string read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

template <typename F>
std::string message(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "<no error>";
}

class SqliteTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cariesim-io-sqlite-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A valid test database with `extra` SQL run after it.
  fs::path make(const std::string& name, const std::string& extra = "") {
    const fs::path file = dir_ / name;
    run_sql(file, std::string(kValidSql) + extra);
    return file;
  }

  fs::path dir_;
};

TEST_F(SqliteTest, AValidDatabaseOpensAndReads) {
  const fs::path file = make("ok.db");
  const auto db = open_input(file, test_schema());
  Statement sum(*db, "SELECT sum(value) FROM items");
  ASSERT_EQ(sum.step(), SQLITE_ROW);
  EXPECT_DOUBLE_EQ(sum.real(0), 4.0);
  EXPECT_EQ(db->access(), "immutable");
  EXPECT_NO_THROW(db->check_input_unchanged());
}

// Each object that is not the schema's is refused by name, and so is a missing one, before any of
// the file's SQL can run.
TEST_F(SqliteTest, ObjectsOtherThanTheSchemasAreRefusedByName) {
  const struct {
    const char* name;
    const char* sql;
    const char* expected;
  } cases[] = {
      {"view.db", "CREATE VIEW shadow AS SELECT * FROM items;", "its 'shadow' is a view"},
      {"trigger.db", "CREATE TRIGGER rewrite AFTER INSERT ON items BEGIN UPDATE items SET value = 10; END;",
       "it holds a trigger 'rewrite' on 'items'"},
      {"table.db", "CREATE TABLE notes (text TEXT);", "it holds a table 'notes'"},
      {"index.db", "CREATE INDEX by_id ON items (id, value);", "it holds an index 'by_id' on 'items'"},
      {"expression-index.db", "DROP INDEX items_by_value; CREATE INDEX items_by_value ON items (value * 2);",
       "its index 'items_by_value' is an expression or partial index"},
      {"partial-index.db",
       "DROP INDEX items_by_value; CREATE INDEX items_by_value ON items (value) WHERE value > 0;",
       "its index 'items_by_value' is an expression or partial index"},
      {"generated.db", "ALTER TABLE items ADD COLUMN twice REAL GENERATED ALWAYS AS (value * 2);",
       "the column 'twice' of 'items' is a generated or hidden column"},
      {"missing.db", "DROP INDEX items_by_value;",
       "not a test database (the index 'items_by_value' is missing)"},
  };
  for (const auto& c : cases) {
    const fs::path file = make(c.name, c.sql);
    EXPECT_THAT(message([&] { open_input(file, test_schema()); }), HasSubstr(file.string() + ": ")) << c.name;
    EXPECT_THAT(message([&] { open_input(file, test_schema()); }), HasSubstr(c.expected)) << c.name;
    EXPECT_THAT(message([&] { open_for_append(file, test_schema()); }), HasSubstr(c.expected)) << c.name;
  }
  // A table the schema has, made a view: never selected from.
  const fs::path view = dir_ / "items-view.db";
  run_sql(
      view,
      "PRAGMA application_id=1413829460; CREATE TABLE version (v INTEGER); INSERT INTO version VALUES (1);"
      "CREATE VIEW items AS WITH RECURSIVE r(id, value) AS (SELECT 1, 1.0 UNION ALL SELECT id + 1, value "
      "FROM r) SELECT * FROM r;");
  EXPECT_THAT(message([&] { open_input(view, test_schema()); }),
              HasSubstr("its 'items' is a view where a test database has a table"));
  // The version table itself a view: refused before it is read.
  const fs::path version_view = dir_ / "version-view.db";
  run_sql(version_view, "PRAGMA application_id=1413829460; CREATE VIEW version AS SELECT 1 AS v;");
  EXPECT_THAT(message([&] { open_input(version_view, test_schema()); }),
              HasSubstr("its 'version' is a view, not a table"));
}

TEST_F(SqliteTest, OtherFilesAreNamedForWhatTheyAre) {
  const fs::path other = dir_ / "other.db";
  run_sql(other, "PRAGMA application_id=1129468749; CREATE TABLE samples (t REAL);");  // "CRSM"
  EXPECT_THAT(message([&] { open_input(other, test_schema()); }),
              HasSubstr("not a test database (application id \"CRSM\", a cariesim session recording"));
  const fs::path text = dir_ / "notes.db";
  std::ofstream(text)
      << "this is a text file long enough for SQLite to look at its first page and refuse it\n";
  EXPECT_THAT(message([&] { open_input(text, test_schema()); }),
              HasSubstr(text.string() + ": not a test database"));
  EXPECT_THAT(message([&] { open_input(dir_ / "absent.db", test_schema()); }),
              HasSubstr("no such test database"));
  EXPECT_THAT(message([&] { open_input(dir_, test_schema()); }),
              HasSubstr("is a folder, not a test database"));
  // A FIFO (as a database or as its -wal) is refused without opening it, so nothing blocks.
  const fs::path fifo = dir_ / "fifo.db";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THAT(message([&] { open_input(fifo, test_schema()); }), HasSubstr("not a regular file (a FIFO"));
  const fs::path with_fifo_wal = make("fifo-wal.db");
  ASSERT_EQ(::mkfifo((with_fifo_wal.string() + "-wal").c_str(), 0600), 0);
  EXPECT_THAT(message([&] { open_input(with_fifo_wal, test_schema()); }),
              HasSubstr("-wal: test database's -wal: not a regular file (a FIFO"));
}

// Even a plain connection (the recorder's, the tests') runs no trigger or view of the file's own.
TEST_F(SqliteTest, EveryConnectionIsDefensive) {
  const fs::path file =
      make("plain.db",
           "CREATE TRIGGER rewrite AFTER INSERT ON items BEGIN UPDATE items SET value = 10; END;"
           "CREATE VIEW doubled AS SELECT value * 2 AS v FROM items;");
  Database db(file, SQLITE_OPEN_READWRITE);
  db.exec("INSERT INTO items (value) VALUES (3.5)", "insert");
  Statement values(db, "SELECT group_concat(value) FROM items");
  ASSERT_EQ(values.step(), SQLITE_ROW);
  EXPECT_EQ(values.text(0), "1.5,2.5,3.5") << "the trigger did not run";
  EXPECT_THROW(Statement(db, "SELECT v FROM doubled"), Error) << "views are off";
  EXPECT_NE(db.try_exec("PRAGMA writable_schema=ON; UPDATE sqlite_master SET sql = 'x'"), SQLITE_OK)
      << "defensive mode: the schema cannot be written directly";
}

// A query that would run without end is stopped by the step bound, and one that fills temporary
// files by the temporary-storage bound; both say so.
TEST_F(SqliteTest, WorkAndTemporaryStorageAreBounded) {
  const fs::path file = make("bounded.db");
  {
    const auto db = open_input(file, test_schema(), {5'000'000, 0});
    const auto start = std::chrono::steady_clock::now();
    Statement spin(*db,
                   "WITH RECURSIVE r(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM r) SELECT count(*) FROM r");
    EXPECT_EQ(spin.step(), SQLITE_INTERRUPT);
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
    EXPECT_THAT(db->message(), HasSubstr("million steps of SQLite's work"));
    // A new budget: ordinary queries run again.
    db->renew_work_budget();
    Statement count(*db, "SELECT count(*) FROM items");
    ASSERT_EQ(count.step(), SQLITE_ROW);
    EXPECT_EQ(count.integer(0), 2);
  }
  {
    const auto db = open_input(file, test_schema(), {std::uint64_t{1} << 40, std::uint64_t{1} << 20});
    db->exec("PRAGMA cache_size=16", "small cache");  // the sort spills to temporary files soon
    Statement sort(*db,
                   "WITH RECURSIVE r(i) AS (SELECT 1 UNION ALL SELECT i + 1 FROM r LIMIT 2000000) "
                   "SELECT i, randomblob(64) FROM r ORDER BY random()");
    EXPECT_EQ(sort.step() & 0xff, SQLITE_FULL);
    EXPECT_THAT(db->message(), HasSubstr("MiB of temporary files"));
  }
}

// An input in WAL mode is read without a -wal or -shm made beside it: at rest as immutable, with a
// writer's -wal and -shm through them, and a .db copied with its -wal through a private copy.
TEST_F(SqliteTest, InputsGetNoFileBesideThem) {
  const fs::path file = make("wal.db", "PRAGMA journal_mode=WAL;");
  ASSERT_FALSE(fs::exists(file.string() + "-wal"));
  const std::string before = read_bytes(file);
  {
    const auto db = open_input(file, test_schema());
    EXPECT_EQ(db->access(), "immutable");
    Statement count(*db, "SELECT count(*) FROM items");
    ASSERT_EQ(count.step(), SQLITE_ROW);
    EXPECT_EQ(count.integer(0), 2);
  }
  EXPECT_FALSE(fs::exists(file.string() + "-wal"));
  EXPECT_FALSE(fs::exists(file.string() + "-shm"));
  EXPECT_EQ(read_bytes(file), before);

  // A writer holds it open with a committed row in its -wal: read through the writer's files.
  sqlite3* writer = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &writer), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(writer, "PRAGMA wal_autocheckpoint=0; INSERT INTO items (value) VALUES (7.0)",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  ASSERT_TRUE(fs::exists(file.string() + "-shm"));
  {
    const auto db = open_input(file, test_schema());
    EXPECT_EQ(db->access(), "shared");
    Statement count(*db, "SELECT count(*) FROM items");
    ASSERT_EQ(count.step(), SQLITE_ROW);
    EXPECT_EQ(count.integer(0), 3);
  }

  // The .db and its -wal copied elsewhere, without the -shm: read through a private copy.
  const fs::path copy = dir_ / "copy.db";
  fs::copy_file(file, copy);
  fs::copy_file(file.string() + "-wal", copy.string() + "-wal");
  sqlite3_close(writer);
  const std::string copy_before = read_bytes(copy);
  {
    const auto db = open_input(copy, test_schema());
    EXPECT_EQ(db->access(), "copy");
    Statement count(*db, "SELECT count(*) FROM items");
    ASSERT_EQ(count.step(), SQLITE_ROW);
    EXPECT_EQ(count.integer(0), 3) << "the row in the -wal is read";
  }
  EXPECT_FALSE(fs::exists(copy.string() + "-shm"));
  EXPECT_EQ(read_bytes(copy), copy_before);
}

// A file at rest that a program starts writing while it is read: the reader is told.
// A memory database is private to its connection and writes no file, not even in the working folder
// (a ":memory:" name turned into a file: URI would be a file of that name there).
TEST_F(SqliteTest, AMemoryDatabaseWritesNoFileAndIsPrivate) {
  const fs::path before = fs::current_path();
  fs::current_path(dir_);
  {
    const auto a = create_memory_database("held a");
    const auto b = create_memory_database("held b");
    EXPECT_EQ(a->access(), "memory");
    a->exec("CREATE TABLE t (x INTEGER)", "create");
    a->exec("INSERT INTO t VALUES (1)", "insert");
    b->exec("CREATE TABLE t (x INTEGER)", "create in the other");  // its own, empty database
    Statement count(*a, "SELECT count(*) FROM t");
    ASSERT_EQ(count.step(), SQLITE_ROW);
    EXPECT_EQ(count.integer(0), 1);
  }
  fs::current_path(before);
  EXPECT_TRUE(fs::is_empty(dir_)) << "a memory database left a file in the working folder";
}

TEST_F(SqliteTest, AnImmutableInputThatChangesIsNoticed) {
  const fs::path file = make("changes.db");
  const auto db = open_input(file, test_schema());
  run_sql(file, "INSERT INTO items (value) VALUES (9.0)");
  EXPECT_THAT(message([&] { db->check_input_unchanged(); }), HasSubstr("changed while it was being read"));
}

// A database another process is writing (holding its write lock) is named as locked, not as "not a
// database".
TEST_F(SqliteTest, ALockedDatabaseIsNamedAsLocked) {
  const fs::path file = make("locked.db");
  int ready[2];
  int release[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(release), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The other program: takes the write lock, says so, holds it until the test lets go.
    sqlite3* db = nullptr;
    char byte = 0;
    const bool locked = sqlite3_open(file.c_str(), &db) == SQLITE_OK &&
                        sqlite3_exec(db, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr) == SQLITE_OK;
    byte = locked ? 'L' : 'E';
    (void)::write(ready[1], &byte, 1);
    (void)::read(release[0], &byte, 1);
    ::_exit(0);
  }
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1);
  ASSERT_EQ(byte, 'L');
  const std::string error = message([&] { open_input(file, test_schema()); });
  (void)::write(release[1], &byte, 1);
  int status = 0;
  ::waitpid(child, &status, 0);
  for (const int fd : {ready[0], ready[1], release[0], release[1]}) ::close(fd);
  EXPECT_THAT(error, HasSubstr(file.string() + ": locked by another program"));
  EXPECT_THAT(error, ::testing::Not(HasSubstr("not a test database")));
  EXPECT_NO_THROW(open_input(file, test_schema())) << "readable once the lock is gone";
}

}  // namespace
}  // namespace cariesim::io
