#include "cariesim/io/sqlite.hpp"

#include <limits>

#include "cariesim/common/error.hpp"

namespace cariesim::io {

// Open the connection; a failed open still allocates a handle that carries the message.
Database::Database(const std::filesystem::path& file, int flags) : file_(file.string()) {
  const int rc = sqlite3_open_v2(file_.c_str(), &db_, flags, nullptr);
  if (rc != SQLITE_OK) {
    const std::string reason = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    close();
    throw Error(file_ + ": cannot open the database: " + reason);
  }
  sqlite3_extended_result_codes(db_, 1);
}

Database::~Database() { close(); }

std::string Database::message() const { return db_ ? sqlite3_errmsg(db_) : "database closed"; }

void Database::exec(const std::string& sql, const std::string& what) {
  if (try_exec(sql) != SQLITE_OK) fail(what);
}

int Database::try_exec(const std::string& sql) {
  return sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr);
}

int Database::close() {
  if (!db_) return SQLITE_OK;
  const int rc = sqlite3_close_v2(db_);
  db_ = nullptr;
  return rc;
}

void Database::fail(const std::string& what) const { throw Error(file_ + ": " + what + ": " + message()); }

Statement::Statement(Database& db, const std::string& sql) {
  if (sqlite3_prepare_v3(db.get(), sql.c_str(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT,
                         &stmt_, nullptr) != SQLITE_OK)
    db.fail("cannot prepare '" + sql.substr(0, 40) + "...'");
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

void Statement::bind(int index, double value) { sqlite3_bind_double(stmt_, index + 1, value); }

void Statement::bind(int index, int64_t value) { sqlite3_bind_int64(stmt_, index + 1, value); }

void Statement::bind(int index, const std::string& value) {
  sqlite3_bind_text(stmt_, index + 1, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
}

int Statement::step() { return sqlite3_step(stmt_); }

void Statement::reset() { sqlite3_reset(stmt_); }

double Statement::real(int column) const {
  if (is_null(column)) return std::numeric_limits<double>::quiet_NaN();
  return sqlite3_column_double(stmt_, column);
}

int64_t Statement::integer(int column) const { return sqlite3_column_int64(stmt_, column); }

std::string Statement::text(int column) const {
  const auto* bytes = sqlite3_column_text(stmt_, column);
  if (!bytes) return {};
  return std::string(reinterpret_cast<const char*>(bytes),
                     static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column)));
}

bool Statement::is_null(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }

}  // namespace cariesim::io
