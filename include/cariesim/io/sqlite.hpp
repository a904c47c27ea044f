#pragma once
// Thin RAII wrappers over SQLite's C API for every database cariesim reads or writes (no ORM): a connection and a prepared
// statement with typed bind/column helpers. Failures at open and prepare throw cariesim::Error naming
// the file and SQLite's reason; step() returns the result code so the writer thread can report
// failures instead of throwing through the servo side.
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <string>

namespace cariesim::io {

/// One connection to a database file.
class Database {
 public:
  /// Opens `file` with sqlite3_open_v2 `flags`; throws cariesim::Error.
  Database(const std::filesystem::path& file, int flags);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  [[nodiscard]] sqlite3* get() const { return db_; }
  [[nodiscard]] const std::string& file() const { return file_; }
  /// SQLite's message for the last failure on this connection.
  [[nodiscard]] std::string message() const;
  /// Runs SQL that returns no rows; throws cariesim::Error "file: what: reason".
  void exec(const std::string& sql, const std::string& what);
  /// Runs SQL, returns the result code (no throw).
  int try_exec(const std::string& sql);
  /// Closes the connection (idempotent); returns SQLite's result code.
  int close();
  /// Throws cariesim::Error "file: what: reason" with this connection's last message.
  [[noreturn]] void fail(const std::string& what) const;

 private:
  sqlite3* db_ = nullptr;
  std::string file_;
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

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

}  // namespace cariesim::io
