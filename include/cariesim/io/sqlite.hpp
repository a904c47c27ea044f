#pragma once
// The one way cariesim opens a SQLite database, and thin RAII wrappers over SQLite's C API (no ORM):
// a connection and a prepared statement with typed bind/column helpers.
//
// Every database that comes from elsewhere (a station database, a study database, a recording) is
// hostile (docs/records.md, "What a recording is trusted to do"): it is opened through open_input
// (reading) or open_for_append (appending), which
//   - refuse anything but a regular file (io/file.hpp), and its -wal/-shm when they are not regular;
//   - set SQLITE_DBCONFIG_DEFENSIVE, turn views and triggers off and trusted_schema off, so no SQL
//     stored in the file ever runs;
//   - check that sqlite_master holds exactly the tables and indexes the caller's Schema names
//     (a view, a trigger, a virtual table, a table of the wrong kind is refused, naming it);
//   - bound the work of every query (a progress handler counting SQLite's virtual machine steps)
//     and the temporary storage (a file-system shim that caps the connection's temporary files), both
//     from the size of the input;
//   - open inputs read-only and never create a -wal or -shm file beside them: a file at rest is
//     read as immutable, a file a writer holds open through its own -wal/-shm, a .db copied with its
//     -wal through a private copy (a read-only medium works too);
//   - say the true cause: a file locked by another program is "locked", not "not a database".
// Failures at open and prepare throw cariesim::Error naming the file and SQLite's reason; step()
// returns the result code so the recorder's writer thread can report failures instead of throwing.
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cariesim/common/error.hpp"

namespace cariesim::io {

/// Thrown when a database is locked by another connection or program (SQLITE_BUSY, SQLITE_LOCKED,
/// or an input another process is writing): nothing is wrong with the file; trying again later may
/// succeed.
class LockedError : public Error {
 public:
  using Error::Error;
};

class Database;
struct BoundedVfs;

/// One table or index a database must hold.
struct SchemaObject {
  enum class Type { Table, Index };
  Type type = Type::Table;
  std::string name;
  /// An index's table (a table's own name for a table).
  std::string table;
  /// A table's columns that must be there as ordinary (not generated, not hidden) columns; a later
  /// writer may add others.
  std::vector<std::string> columns;
  /// May be missing (a table a later schema version added, absent from older files); when there it
  /// is checked like the others. The version check (Schema::identify) says which must be there.
  bool optional = false;
};

/// What a database of one kind holds: its application id, its version check and exactly its
/// tables and indexes (and the indexes SQLite makes itself for their UNIQUE and PRIMARY KEY
/// constraints, `sqlite_autoindex_TABLE_N`).
struct Schema {
  /// Named in every message: "FILE: not a WHAT (...)".
  std::string what;
  /// PRAGMA application_id the file must carry.
  std::int32_t application_id = 0;
  /// Other known application ids and what they are ("a cariesim session recording"), for messages.
  std::vector<std::pair<std::int32_t, std::string>> known_applications;
  /// A table read by `identify` before the object check (e.g. "schema_version"); checked first to be
  /// an ordinary table. Empty: none.
  std::string version_table;
  /// Reads and checks the version row (may only read `version_table`); throws cariesim::Error.
  std::function<void(Database&)> identify;
  /// Exactly these tables and indexes.
  std::vector<SchemaObject> objects;
};

/// Bounds of the work SQLite may do on one connection (0: derived from the input's size).
struct WorkLimits {
  /// SQLite virtual-machine steps since the last set_work_budget() (or the open).
  std::uint64_t steps = 0;
  /// Bytes of temporary files (sorts, materialised subqueries) the connection may hold at once.
  std::uint64_t temp_bytes = 0;
};

/// Steps a connection on a file of `bytes` bytes may run by default: kBaseSteps + kStepsPerByte per
/// byte (reading every row of a recording or a study database takes under 0.5 steps per byte).
inline constexpr std::uint64_t kBaseSteps = std::uint64_t{200'000'000};
inline constexpr std::uint64_t kStepsPerByte = 16;
/// Temporary bytes a connection on a file of `bytes` bytes may hold by default: 64 MiB + the file's size.
inline constexpr std::uint64_t kBaseTempBytes = std::uint64_t{64} << 20;
/// The default limits for an input of `bytes` bytes.
WorkLimits default_limits(std::uintmax_t bytes);

/// Opens a database that is an input (a recording to load, export or replay; a study database to
/// report), read-only, never creating a file beside it, with `schema` checked and the work bounded
/// (`limits`, 0 fields derived from the file's size). Throws cariesim::Error naming the file and the
/// true cause: "no such WHAT", "is a folder", "not a regular file", "locked by another program",
/// "not a WHAT (...)", "holds a view 'x'", ...
std::unique_ptr<Database> open_input(const std::filesystem::path& file, const Schema& schema,
                                     const WorkLimits& limits = {});

/// Opens an existing database to append to it (a study database), read-write, with `schema` checked
/// (so no trigger or view of the file's own is there to run, even for another program), the
/// defensive settings and a busy timeout of 2 s. Throws cariesim::Error naming the file and the
/// cause (LockedError when another program holds it locked).
std::unique_ptr<Database> open_for_append(const std::filesystem::path& file, const Schema& schema);

/// Creates a new database at `file` (which the caller has just claimed, e.g. with O_EXCL, or which
/// must not exist yet), read-write, with the defensive settings. Throws cariesim::Error.
std::unique_ptr<Database> create_database(const std::filesystem::path& file);

/// Creates a private database in memory, with the defensive settings; it writes no file (not even
/// one named after `name`, which only names it in messages). Throws cariesim::Error.
std::unique_ptr<Database> create_memory_database(const std::string& name);

/// One connection to a database file.
class Database {
 public:
  /// Opens `file` with sqlite3_open_v2 `flags` and the defensive settings every connection gets
  /// (SQLITE_DBCONFIG_DEFENSIVE, no views, no triggers, trusted_schema off, no extensions); no schema
  /// check, no bound on the work. For databases cariesim creates itself and for tests; everything
  /// else opens through open_input / open_for_append / create_database. Throws cariesim::Error.
  Database(const std::filesystem::path& file, int flags);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  [[nodiscard]] sqlite3* get() const { return db_; }
  /// The file as given (the original, also when a private copy is read).
  [[nodiscard]] const std::string& file() const { return file_; }
  /// SQLite's message for the last failure on this connection, with the true cause when it was the
  /// work or temporary-storage bound, or another program's lock.
  [[nodiscard]] std::string message() const;
  /// True when the last failure was another connection's lock (SQLITE_BUSY / SQLITE_LOCKED).
  [[nodiscard]] bool busy() const;
  /// Runs SQL that returns no rows; throws cariesim::Error "file: what: reason".
  void exec(const std::string& sql, const std::string& what);
  /// Runs SQL, returns the result code (no throw).
  int try_exec(const std::string& sql);
  /// Closes the connection (idempotent); returns SQLite's result code.
  int close();
  /// Throws cariesim::Error "file: what: reason" with this connection's last message; a LockedError
  /// when the failure was another connection's lock.
  [[noreturn]] void fail(const std::string& what) const;

  /// Checks that the database holds exactly `schema`'s objects; throws cariesim::Error naming the first
  /// object that is not one of them, is of another kind, or is missing.
  void check_schema(const Schema& schema);
  /// Bounds the steps of the queries that follow (counted from now) and the temporary bytes; 0
  /// steps: no bound.
  void set_work_limits(const WorkLimits& limits);
  /// Restarts the step count (e.g. per batch of a stream that reads a file many times over).
  void renew_work_budget();
  /// For a file read as immutable (at rest): throws cariesim::Error when it changed since it was
  /// opened (another program started writing it), since what was read may then be inconsistent.
  void check_input_unchanged() const;
  /// How the input was opened, for messages and tests: "immutable", "shared" (with a writer's
  /// -wal/-shm), "copy" (a private copy of the file and its -wal), "append", "new" or "plain".
  [[nodiscard]] std::string_view access() const { return access_; }

 private:
  friend std::unique_ptr<Database> open_input(const std::filesystem::path&, const Schema&, const WorkLimits&);
  friend std::unique_ptr<Database> open_for_append(const std::filesystem::path&, const Schema&);
  friend std::unique_ptr<Database> create_database(const std::filesystem::path&);
  friend std::unique_ptr<Database> create_memory_database(const std::string&);
  friend struct BoundedVfs;
  struct Bounds;
  // Opens `uri` (a file: URI) through this connection's bounded file system with `limits` in force
  // from the first statement on; `file` names it in messages.
  Database(std::string file, const std::string& uri, int flags, std::string_view access,
           const WorkLimits& limits);
  // The defensive settings and pragmas of every connection.
  void configure();
  // SQLite's progress callback: counts steps, interrupts past the bound.
  static int on_progress(void* self);

  sqlite3* db_ = nullptr;
  std::string file_;
  std::string_view access_ = "plain";
  std::unique_ptr<Bounds> bounds_;
  // Filled by the openers: the copy to remove, the stat of an immutable input.
  std::filesystem::path private_copy_;
  struct Identity {
    std::uintmax_t device = 0, inode = 0, size = 0;
    std::int64_t mtime_ns = 0;
  };
  Identity identity_;
  bool immutable_ = false;
};

/// A prepared statement; columns and parameters are 0-based (parameters shifted to SQLite's 1-based).
class Statement {
 public:
  /// Prepares `sql` for reuse; throws cariesim::Error.
  Statement(Database& db, const std::string& sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  /// Binds a double; a NaN is stored as NULL (SQLite's own rule) and read back as NaN.
  void bind(int index, double value);
  void bind(int index, int64_t value);
  void bind(int index, const std::string& value);
  /// sqlite3_step: SQLITE_ROW, SQLITE_DONE or an error code.
  int step();
  /// Resets for the next execution (bindings are kept until rebound).
  void reset();
  /// A REAL column; NULL reads as NaN.
  [[nodiscard]] double real(int column) const;
  [[nodiscard]] int64_t integer(int column) const;
  /// A TEXT column; NULL reads as "".
  [[nodiscard]] std::string text(int column) const;
  [[nodiscard]] bool is_null(int column) const;
  /// The stored type of a column of the current row: SQLITE_INTEGER, SQLITE_FLOAT, SQLITE_TEXT,
  /// SQLITE_BLOB or SQLITE_NULL.
  [[nodiscard]] int type(int column) const;

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

/// "REAL", "INTEGER", "TEXT", "BLOB", "NULL": a stored type in words, for messages.
std::string_view type_name(int sqlite_type);

}  // namespace cariesim::io
