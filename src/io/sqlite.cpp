#include "cariesim/io/sqlite.hpp"

#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <limits>

#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"

namespace cariesim::io {

namespace fs = std::filesystem;

namespace {

// SQLite calls the progress handler every this many virtual-machine steps.
constexpr int kProgressInterval = 1000;
// bytes: the largest text or blob value a connection reads or writes (SQLITE_LIMIT_LENGTH); the
// longest cariesim stores (a session's parameters, a trial's answers) is a few kB.
constexpr int kMaxValueBytes = 16 << 20;
// ms a reader waits for a writer's lock on a file it shares with it (a checkpoint, a commit).
constexpr int kReaderBusyMs = 2000;
// SQLite's lock bytes in a database file (os_unix.c: PENDING_BYTE, then RESERVED, then 510 SHARED).
constexpr off_t kLockFirstByte = 0x40000000;
constexpr off_t kLockBytes = 512;

// The temporary files of a connection: everything SQLite opens without a name or as a temporary
// database, journal or sub-journal (sorts, materialised subqueries, statement journals).
constexpr int kTemporaryFlags =
    SQLITE_OPEN_TEMP_DB | SQLITE_OPEN_TEMP_JOURNAL | SQLITE_OPEN_TRANSIENT_DB | SQLITE_OPEN_SUBJOURNAL;

std::atomic<std::uint64_t> vfs_counter{0};

// "file:" URI of a path: every byte but the unreserved ones and '/' percent-encoded.
std::string file_uri(const fs::path& file, std::string_view parameters) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string uri = "file:";
  for (const char c : fs::absolute(file).lexically_normal().string()) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) != 0 || c == '/' || c == '.' || c == '_' || c == '-' || c == '~') {
      uri.push_back(c);
    } else {
      uri.push_back('%');
      uri.push_back(kHex[u >> 4]);
      uri.push_back(kHex[u & 15]);
    }
  }
  if (!parameters.empty()) uri += "?" + std::string(parameters);
  return uri;
}

bool starts_with_nocase(std::string_view text, std::string_view prefix) {
  std::size_t i = 0;
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i])) != 0) ++i;
  text.remove_prefix(i);
  if (text.size() < prefix.size()) return false;
  for (std::size_t k = 0; k < prefix.size(); ++k)
    if (std::tolower(static_cast<unsigned char>(text[k])) !=
        std::tolower(static_cast<unsigned char>(prefix[k])))
      return false;
  return true;
}

// The application id in words: its four characters ("CRST") when printable, else its number.
std::string application_name(std::int32_t id) {
  std::string name;
  for (int shift = 24; shift >= 0; shift -= 8) {
    const char c = static_cast<char>((static_cast<std::uint32_t>(id) >> shift) & 0xFFU);
    if (c < 0x20 || c > 0x7E) return std::to_string(id);
    name.push_back(c);
  }
  return "\"" + name + "\"";
}

// True when another process holds a write lock (RESERVED, PENDING or EXCLUSIVE) on the database
// file: it is being written in a way that leaves no -shm beside it (a rollback journal, or WAL in
// exclusive locking mode), so it is not at rest and cannot be read as immutable.
bool write_locked_by_another_process(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return false;
  struct flock probe {};
  probe.l_type = F_RDLCK;
  probe.l_whence = SEEK_SET;
  probe.l_start = kLockFirstByte;
  probe.l_len = kLockBytes + 2;
  const bool locked = ::fcntl(fd, F_GETLK, &probe) == 0 && probe.l_type != F_UNLCK;
  ::close(fd);
  return locked;
}

// Size of a file, 0 when absent.
std::uintmax_t size_or_zero(const fs::path& file) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(file, ec);
  return ec ? 0 : size;
}

// Checks what a path beside the database (-wal, -shm) is, when something is there: a FIFO or a
// device there would block SQLite or feed it without end.
bool regular_sidecar(const fs::path& path, const std::string& what) {
  const FileKind kind = file_kind(path);
  if (kind == FileKind::Missing) return false;
  if (kind != FileKind::Regular)
    throw Error(path.string() + ": " + what + ": not a regular file (" + std::string(describe(kind)) + ")");
  return true;
}

}  // namespace

WorkLimits default_limits(std::uintmax_t bytes) {
  const std::uint64_t size = bytes;
  const std::uint64_t cap = std::numeric_limits<std::uint64_t>::max() / (2 * kStepsPerByte);
  const std::uint64_t capped = std::min(size, cap);
  return {kBaseSteps + kStepsPerByte * capped, kBaseTempBytes + capped};
}

// ---------------------------------------------------------------------------------------------------
// The bounded file system: the default VFS, with the connection's temporary files counted and capped.

struct Database::Bounds {
  sqlite3_vfs vfs{};            // this connection's file system (registered under `name`)
  sqlite3_vfs* real = nullptr;  // the default one it forwards to
  std::string name;
  bool registered = false;
  std::uint64_t max_steps = 0;  // 0: no bound
  std::uint64_t steps = 0;
  bool steps_exceeded = false;
  std::uint64_t max_temp = 0;  // bytes, 0: no bound
  std::atomic<std::uint64_t> temp{0};
  std::atomic<bool> temp_exceeded{false};
};

namespace {

// A temporary file: our header, then the real file at kRealOffset.
struct TempFile {
  sqlite3_file base;      // base.pMethods = &kTempMethods
  void* bounds;           // Database::Bounds*
  sqlite3_int64 charged;  // bytes counted for this file
};
constexpr std::size_t kRealOffset = (sizeof(TempFile) + 15) / 16 * 16;

sqlite3_file* real_file(sqlite3_file* file) {
  return reinterpret_cast<sqlite3_file*>(reinterpret_cast<char*>(file) + kRealOffset);
}

}  // namespace

// The shim's callbacks (a friend of Database, for its Bounds).
struct BoundedVfs {
  static Database::Bounds& bounds_of(sqlite3_vfs* vfs) {
    return *static_cast<Database::Bounds*>(vfs->pAppData);
  }
  static Database::Bounds& bounds_of(sqlite3_file* file) {
    return *static_cast<Database::Bounds*>(reinterpret_cast<TempFile*>(file)->bounds);
  }
  static sqlite3_vfs* real(sqlite3_vfs* vfs) { return bounds_of(vfs).real; }

  // Temporary files: writes beyond the connection's bound fail as a full disk would.
  static int close(sqlite3_file* file) {
    auto* t = reinterpret_cast<TempFile*>(file);
    sqlite3_file* r = real_file(file);
    const int rc = r->pMethods->xClose(r);
    bounds_of(file).temp -= static_cast<std::uint64_t>(t->charged);
    t->charged = 0;
    return rc;
  }
  static int read(sqlite3_file* file, void* buffer, int amount, sqlite3_int64 offset) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xRead(r, buffer, amount, offset);
  }
  static int write(sqlite3_file* file, const void* buffer, int amount, sqlite3_int64 offset) {
    auto* t = reinterpret_cast<TempFile*>(file);
    Database::Bounds& b = bounds_of(file);
    const sqlite3_int64 end = offset + amount;
    if (end > t->charged) {
      const auto more = static_cast<std::uint64_t>(end - t->charged);
      if (b.max_temp > 0 && b.temp.load() + more > b.max_temp) {
        b.temp_exceeded = true;
        return SQLITE_FULL;
      }
      b.temp += more;
      t->charged = end;
    }
    sqlite3_file* r = real_file(file);
    return r->pMethods->xWrite(r, buffer, amount, offset);
  }
  static int truncate(sqlite3_file* file, sqlite3_int64 size) {
    auto* t = reinterpret_cast<TempFile*>(file);
    sqlite3_file* r = real_file(file);
    const int rc = r->pMethods->xTruncate(r, size);
    if (rc == SQLITE_OK && size < t->charged) {
      bounds_of(file).temp -= static_cast<std::uint64_t>(t->charged - size);
      t->charged = size;
    }
    return rc;
  }
  static int sync(sqlite3_file* file, int flags) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xSync(r, flags);
  }
  static int file_size(sqlite3_file* file, sqlite3_int64* size) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xFileSize(r, size);
  }
  static int lock(sqlite3_file* file, int level) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xLock(r, level);
  }
  static int unlock(sqlite3_file* file, int level) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xUnlock(r, level);
  }
  static int check_reserved(sqlite3_file* file, int* out) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xCheckReservedLock(r, out);
  }
  // A size hint would grow the file without a write: not passed on.
  static int file_control(sqlite3_file* file, int op, void* arg) {
    if (op == SQLITE_FCNTL_SIZE_HINT) return SQLITE_OK;
    sqlite3_file* r = real_file(file);
    return r->pMethods->xFileControl(r, op, arg);
  }
  static int sector_size(sqlite3_file* file) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xSectorSize(r);
  }
  static int device_characteristics(sqlite3_file* file) {
    sqlite3_file* r = real_file(file);
    return r->pMethods->xDeviceCharacteristics(r);
  }

  static const sqlite3_io_methods kTempMethods;

  // Opening: named database files, their journals and WAL go to the real VFS untouched (so locks
  // and shared memory work as always); temporary files get the counting methods.
  static int open(sqlite3_vfs* vfs, const char* name, sqlite3_file* file, int flags, int* out_flags) {
    sqlite3_vfs* r = real(vfs);
    const bool temporary = name == nullptr || (flags & kTemporaryFlags) != 0;
    if (!temporary) return r->xOpen(r, name, file, flags, out_flags);
    auto* t = reinterpret_cast<TempFile*>(file);
    t->base.pMethods = nullptr;
    sqlite3_file* inner = real_file(file);
    inner->pMethods = nullptr;
    const int rc = r->xOpen(r, name, inner, flags, out_flags);
    if (rc != SQLITE_OK) {
      if (inner->pMethods != nullptr) inner->pMethods->xClose(inner);
      return rc;
    }
    t->bounds = vfs->pAppData;
    t->charged = 0;
    t->base.pMethods = &kTempMethods;
    return SQLITE_OK;
  }
  static int remove(sqlite3_vfs* vfs, const char* name, int sync_dir) {
    return real(vfs)->xDelete(real(vfs), name, sync_dir);
  }
  static int access(sqlite3_vfs* vfs, const char* name, int flags, int* out) {
    return real(vfs)->xAccess(real(vfs), name, flags, out);
  }
  static int full_pathname(sqlite3_vfs* vfs, const char* name, int size, char* out) {
    return real(vfs)->xFullPathname(real(vfs), name, size, out);
  }
  static void* dl_open(sqlite3_vfs*, const char*) { return nullptr; }  // extensions are never loaded
  static void dl_error(sqlite3_vfs*, int size, char* out) {
    if (size > 0) std::snprintf(out, static_cast<std::size_t>(size), "extensions are not loaded");
  }
  static void (*dl_sym(sqlite3_vfs*, void*, const char*))(void) { return nullptr; }
  static void dl_close(sqlite3_vfs*, void*) {}
  static int randomness(sqlite3_vfs* vfs, int size, char* out) {
    return real(vfs)->xRandomness(real(vfs), size, out);
  }
  static int sleep(sqlite3_vfs* vfs, int microseconds) { return real(vfs)->xSleep(real(vfs), microseconds); }
  static int current_time(sqlite3_vfs* vfs, double* out) { return real(vfs)->xCurrentTime(real(vfs), out); }
  static int last_error(sqlite3_vfs* vfs, int size, char* out) {
    return real(vfs)->xGetLastError(real(vfs), size, out);
  }
  static int current_time_int64(sqlite3_vfs* vfs, sqlite3_int64* out) {
    sqlite3_vfs* r = real(vfs);
    if (r->iVersion >= 2 && r->xCurrentTimeInt64 != nullptr) return r->xCurrentTimeInt64(r, out);
    double days = 0.0;
    const int rc = r->xCurrentTime(r, &days);
    *out = static_cast<sqlite3_int64>(days * 86400000.0);
    return rc;
  }

  // Fills `b.vfs` from the default VFS and registers it under a name of its own.
  static void install(Database::Bounds& b) {
    b.real = sqlite3_vfs_find(nullptr);
    if (b.real == nullptr) throw Error("SQLite has no default file system");
    b.name = "cariesim-bounded-" + std::to_string(vfs_counter.fetch_add(1));
    sqlite3_vfs& v = b.vfs;
    v.iVersion = 2;
    v.szOsFile = static_cast<int>(kRealOffset) + b.real->szOsFile;
    v.mxPathname = b.real->mxPathname;
    v.zName = b.name.c_str();
    v.pAppData = &b;
    v.xOpen = open;
    v.xDelete = remove;
    v.xAccess = access;
    v.xFullPathname = full_pathname;
    v.xDlOpen = dl_open;
    v.xDlError = dl_error;
    v.xDlSym = dl_sym;
    v.xDlClose = dl_close;
    v.xRandomness = randomness;
    v.xSleep = sleep;
    v.xCurrentTime = current_time;
    v.xGetLastError = last_error;
    v.xCurrentTimeInt64 = current_time_int64;
    if (sqlite3_vfs_register(&v, 0) != SQLITE_OK) throw Error("cannot register SQLite's bounded file system");
    b.registered = true;
  }
};

const sqlite3_io_methods BoundedVfs::kTempMethods = {1,
                                                     BoundedVfs::close,
                                                     BoundedVfs::read,
                                                     BoundedVfs::write,
                                                     BoundedVfs::truncate,
                                                     BoundedVfs::sync,
                                                     BoundedVfs::file_size,
                                                     BoundedVfs::lock,
                                                     BoundedVfs::unlock,
                                                     BoundedVfs::check_reserved,
                                                     BoundedVfs::file_control,
                                                     BoundedVfs::sector_size,
                                                     BoundedVfs::device_characteristics,
                                                     nullptr,
                                                     nullptr,
                                                     nullptr,
                                                     nullptr,
                                                     nullptr,
                                                     nullptr};

// ---------------------------------------------------------------------------------------------------
// Database

// A plain open (databases cariesim makes itself, tests): defensive settings, no bounds.
Database::Database(const fs::path& file, int flags)
    : Database(file.string(), file_uri(file, ""), flags | SQLITE_OPEN_URI, "plain", {}) {}

// Open through this connection's own bounded VFS; a failed open still allocates a handle that
// carries the message.
Database::Database(std::string file, const std::string& uri, int flags, std::string_view access,
                   const WorkLimits& limits)
    : file_(std::move(file)), access_(access), bounds_(std::make_unique<Bounds>()) {
  BoundedVfs::install(*bounds_);
  bounds_->max_steps = limits.steps;
  bounds_->max_temp = limits.temp_bytes;
  const int rc = sqlite3_open_v2(uri.c_str(), &db_, flags | SQLITE_OPEN_URI, bounds_->name.c_str());
  if (rc != SQLITE_OK) {
    const std::string reason = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    close();
    throw Error(file_ + ": cannot open the database: " + reason);
  }
  try {
    configure();
  } catch (...) {
    close();
    throw;
  }
}

// The settings of every connection: SQL stored in the file never runs (no views, no triggers,
// untrusted schema, defensive mode), no extension, no attached file, bounded values, temporary
// files on disk where the shim counts them, the progress handler.
void Database::configure() {
  sqlite3_extended_result_codes(db_, 1);
  int applied = 0;
  const bool ok =
      sqlite3_db_config(db_, SQLITE_DBCONFIG_DEFENSIVE, 1, &applied) == SQLITE_OK && applied == 1 &&
      sqlite3_db_config(db_, SQLITE_DBCONFIG_ENABLE_VIEW, 0, &applied) == SQLITE_OK && applied == 0 &&
      sqlite3_db_config(db_, SQLITE_DBCONFIG_ENABLE_TRIGGER, 0, &applied) == SQLITE_OK && applied == 0 &&
      sqlite3_db_config(db_, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, &applied) == SQLITE_OK && applied == 0 &&
      sqlite3_db_config(db_, SQLITE_DBCONFIG_ENABLE_LOAD_EXTENSION, 0, &applied) == SQLITE_OK;
  if (!ok) fail("cannot apply SQLite's defensive settings");
  sqlite3_limit(db_, SQLITE_LIMIT_ATTACHED, 0);
  sqlite3_limit(db_, SQLITE_LIMIT_LENGTH, kMaxValueBytes);
  sqlite3_progress_handler(db_, kProgressInterval, &Database::on_progress, this);
  exec("PRAGMA trusted_schema=OFF", "cannot turn trusted_schema off");
  exec("PRAGMA temp_store=FILE", "cannot keep temporary storage in files");
  exec("PRAGMA mmap_size=0", "cannot turn memory mapping off");
}

Database::~Database() { close(); }

int Database::on_progress(void* self) {
  Bounds& b = *static_cast<Database*>(self)->bounds_;
  b.steps += kProgressInterval;
  if (b.max_steps > 0 && b.steps > b.max_steps) {
    b.steps_exceeded = true;
    return 1;
  }
  return 0;
}

bool Database::busy() const {
  if (!db_) return false;
  const int code = sqlite3_extended_errcode(db_) & 0xff;
  return code == SQLITE_BUSY || code == SQLITE_LOCKED;
}

std::string Database::message() const {
  if (!db_) return "database closed";
  const std::string sqlite = sqlite3_errmsg(db_);
  if (bounds_ && bounds_->steps_exceeded)
    return "stopped after " + std::to_string(bounds_->steps / 1000000) +
           " million steps of SQLite's work, more than any query of cariesim needs on a file of this size "
           "(the file makes a query run without end: " +
           sqlite + ")";
  if (bounds_ && bounds_->temp_exceeded)
    return "stopped at " + std::to_string(bounds_->max_temp >> 20) +
           " MiB of temporary files, more than any query of cariesim needs on a file of this size (" +
           sqlite + ")";
  if (busy()) return "locked by another program (" + sqlite + "); try again when that program has closed it";
  return sqlite;
}

void Database::exec(const std::string& sql, const std::string& what) {
  if (try_exec(sql) != SQLITE_OK) fail(what);
}

int Database::try_exec(const std::string& sql) {
  return sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr);
}

// Closing, then unregistering the connection's VFS and removing a private copy. A connection that
// cannot close (a statement still open) keeps its VFS registered for good.
int Database::close() {
  int rc = SQLITE_OK;
  if (db_) {
    rc = sqlite3_close(db_);
    if (rc != SQLITE_OK) {
      sqlite3_close_v2(db_);
      db_ = nullptr;
      (void)bounds_.release();  // the zombie connection still uses its VFS
      return rc;
    }
    db_ = nullptr;
  }
  if (bounds_ && bounds_->registered) {
    sqlite3_vfs_unregister(&bounds_->vfs);
    bounds_->registered = false;
  }
  if (!private_copy_.empty()) {
    std::error_code ec;
    fs::remove_all(private_copy_, ec);
    private_copy_.clear();
  }
  return rc;
}

void Database::fail(const std::string& what) const {
  if (busy()) throw LockedError(file_ + ": " + what + ": " + message());
  throw Error(file_ + ": " + what + ": " + message());
}

void Database::set_work_limits(const WorkLimits& limits) {
  bounds_->max_steps = limits.steps;
  bounds_->max_temp = limits.temp_bytes;
  renew_work_budget();
}

void Database::renew_work_budget() {
  bounds_->steps = 0;
  bounds_->steps_exceeded = false;
  bounds_->temp_exceeded = false;
}

void Database::check_input_unchanged() const {
  if (!immutable_) return;
  struct stat st {};
  const bool same =
      ::stat(file_.c_str(), &st) == 0 && static_cast<std::uintmax_t>(st.st_dev) == identity_.device &&
      static_cast<std::uintmax_t>(st.st_ino) == identity_.inode &&
      static_cast<std::uintmax_t>(st.st_size) == identity_.size &&
      static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec == identity_.mtime_ns;
  if (!same)
    throw Error(file_ +
                ": changed while it was being read (another program is writing it); read it again when "
                "that program has closed it");
}

// The objects of sqlite_master against the schema: each one expected and of its kind, none missing,
// every table ordinary (no virtual table, no generated or hidden column), every index a plain one.
void Database::check_schema(const Schema& schema) {
  struct Row {
    std::string type, name, table, sql;
    bool has_sql = false;
  };
  std::vector<Row> rows;
  {
    Statement master(*this, "SELECT type, name, tbl_name, sql FROM sqlite_master");
    int rc = SQLITE_ROW;
    while ((rc = master.step()) == SQLITE_ROW)
      rows.push_back({master.text(0), master.text(1), master.text(2), master.text(3), !master.is_null(3)});
    if (rc != SQLITE_DONE) fail("cannot read the schema");
  }
  const std::string where = file_ + ": refused: ";
  const std::string rule =
      " (a " + schema.what + " holds only its own tables and indexes, and no SQL stored in a file is run)";
  const auto expected = [&](SchemaObject::Type type, const std::string& name) -> const SchemaObject* {
    for (const SchemaObject& o : schema.objects)
      if (o.type == type && o.name == name) return &o;
    return nullptr;
  };
  std::vector<std::string> seen;
  for (const Row& row : rows) {
    const SchemaObject* table = expected(SchemaObject::Type::Table, row.name);
    if (row.type == "table") {
      if (table == nullptr)
        throw Error(where + "it holds a table '" + row.name + "' that a " + schema.what + " does not have" +
                    rule);
      if (!row.has_sql || !starts_with_nocase(row.sql, "CREATE TABLE"))
        throw Error(where + "its '" + row.name + "' is a virtual table, not an ordinary table" + rule);
    } else if (row.type == "index") {
      const SchemaObject* index = expected(SchemaObject::Type::Index, row.name);
      const bool automatic = !row.has_sql && row.name.starts_with("sqlite_autoindex_" + row.table + "_") &&
                             expected(SchemaObject::Type::Table, row.table) != nullptr;
      if (!automatic && (index == nullptr || index->table != row.table || !row.has_sql))
        throw Error(where + "it holds an index '" + row.name + "' on '" + row.table + "' that a " +
                    schema.what + " does not have" + rule);
    } else if (row.type == "view") {
      throw Error(
          where + "its '" + row.name + "' is a view" +
          (table != nullptr ? std::string(" where a ") + schema.what + " has a table" : std::string()) +
          rule);
    } else if (row.type == "trigger") {
      throw Error(where + "it holds a trigger '" + row.name + "' on '" + row.table + "'" + rule);
    } else {
      throw Error(where + "it holds a " + row.type + " '" + row.name + "'" + rule);
    }
    seen.push_back(row.type + ":" + row.name);
  }
  // Every expected object is there.
  const auto present = [&](const SchemaObject& o) {
    const bool is_table = o.type == SchemaObject::Type::Table;
    return std::find(seen.begin(), seen.end(), (is_table ? "table:" : "index:") + o.name) != seen.end();
  };
  for (const SchemaObject& o : schema.objects) {
    const bool is_table = o.type == SchemaObject::Type::Table;
    if (o.optional) continue;
    if (std::find(seen.begin(), seen.end(), (is_table ? "table:" : "index:") + o.name) == seen.end())
      throw Error(file_ + ": not a " + schema.what + " (the " + (is_table ? "table" : "index") + " '" +
                  o.name + "' is missing)");
  }
  // Tables: ordinary columns only (a generated column computes SQL of the file's own), the ones
  // the readers need present.
  for (const SchemaObject& o : schema.objects) {
    if (o.type != SchemaObject::Type::Table || !present(o)) continue;
    Statement columns(*this, "SELECT name, hidden FROM pragma_table_xinfo(?)");
    columns.bind(0, o.name);
    std::vector<std::string> names;
    int rc = SQLITE_ROW;
    while ((rc = columns.step()) == SQLITE_ROW) {
      if (columns.integer(1) != 0)
        throw Error(where + "the column '" + columns.text(0) + "' of '" + o.name +
                    "' is a generated or hidden column" + rule);
      names.push_back(columns.text(0));
    }
    if (rc != SQLITE_DONE) fail("cannot read the columns of " + o.name);
    for (const std::string& c : o.columns)
      if (std::find(names.begin(), names.end(), c) == names.end())
        throw Error(file_ + ": not a " + schema.what + " (the table '" + o.name + "' has no column '" + c +
                    "')");
  }
  // Indexes: on plain columns, not partial (an expression or a WHERE clause is SQL of the file's own).
  for (const SchemaObject& o : schema.objects) {
    if (o.type != SchemaObject::Type::Index || !present(o)) continue;
    Statement keys(*this, "SELECT count(*) FROM pragma_index_xinfo(?) WHERE key = 1 AND cid < 0");
    keys.bind(0, o.name);
    if (keys.step() != SQLITE_ROW) fail("cannot read the index " + o.name);
    Statement partial(*this, "SELECT count(*) FROM pragma_index_list(?) WHERE name = ? AND partial != 0");
    partial.bind(0, o.table);
    partial.bind(1, o.name);
    if (partial.step() != SQLITE_ROW) fail("cannot read the index " + o.name);
    if (keys.integer(0) != 0 || partial.integer(0) != 0)
      throw Error(where + "its index '" + o.name + "' is an expression or partial index" + rule);
  }
}

// ---------------------------------------------------------------------------------------------------
// The openers

namespace {

// The application id, the version row, then the objects; a lock on the way is named as such.
void identify_and_check(Database& db, const Schema& schema) {
  std::int32_t id = 0;
  {
    std::unique_ptr<Statement> pragma;
    try {
      pragma = std::make_unique<Statement>(db, "PRAGMA application_id");
    } catch (const Error&) {
      if (db.busy()) db.fail("cannot read the database");
      throw Error(db.file() + ": not a " + schema.what + " (" + db.message() + ")");
    }
    if (pragma->step() != SQLITE_ROW) {
      if (db.busy()) db.fail("cannot read the database");
      throw Error(db.file() + ": not a " + schema.what + " (" + db.message() + ")");
    }
    id = static_cast<std::int32_t>(pragma->integer(0));
  }
  if (schema.application_id != 0 && id != schema.application_id) {
    std::string known;
    for (const auto& [other, name] : schema.known_applications)
      if (other == id) known = ", " + name;
    throw Error(db.file() + ": not a " + schema.what + " (application id " + application_name(id) + known +
                "; a " + schema.what + " has " + application_name(schema.application_id) + ")");
  }
  if (!schema.version_table.empty()) {
    Statement kind(db, "SELECT type, sql FROM sqlite_master WHERE name = ?");
    kind.bind(0, schema.version_table);
    const int rc = kind.step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) db.fail("cannot read the schema");
    if (rc == SQLITE_DONE)
      throw Error(db.file() + ": not a " + schema.what + " (no " + schema.version_table + " table)");
    if (kind.text(0) != "table" || !starts_with_nocase(kind.text(1), "CREATE TABLE"))
      throw Error(db.file() + ": refused: its '" + schema.version_table + "' is a " + kind.text(0) +
                  ", not a table (a " + schema.what +
                  " holds only its own tables and indexes, and no SQL stored "
                  "in a file is run)");
  }
  if (schema.identify) schema.identify(db);
  db.check_schema(schema);
}

// Refuses what is not a regular file, before SQLite opens it.
void require_database_file(const fs::path& file, const Schema& schema) {
  const FileKind kind = file_kind(file);
  if (kind == FileKind::Missing) throw Error(file.string() + ": no such " + schema.what);
  if (kind == FileKind::Directory) throw Error(file.string() + ": is a folder, not a " + schema.what);
  require_regular_file(file, schema.what, std::numeric_limits<std::uintmax_t>::max());
}

}  // namespace

std::unique_ptr<Database> open_input(const fs::path& file, const Schema& schema, const WorkLimits& limits) {
  require_database_file(file, schema);
  const fs::path wal = file.string() + "-wal";
  const fs::path shm = file.string() + "-shm";
  const bool has_wal = regular_sidecar(wal, schema.what + "'s -wal");
  const bool has_shm = regular_sidecar(shm, schema.what + "'s -shm");
  const std::uintmax_t wal_bytes = has_wal ? size_or_zero(wal) : 0;
  WorkLimits bounds = default_limits(size_or_zero(file) + wal_bytes);
  if (limits.steps > 0) bounds.steps = limits.steps;
  if (limits.temp_bytes > 0) bounds.temp_bytes = limits.temp_bytes;
  constexpr int kFlags = SQLITE_OPEN_READONLY | SQLITE_OPEN_URI;

  std::unique_ptr<Database> db;
  if (has_wal && has_shm) {
    // A writer holds it open (or was killed while it did): read it with the writer's -wal and -shm,
    // which are there already, so nothing new is made beside the file.
    db.reset(new Database(file.string(), file_uri(file, "mode=ro"), kFlags, "shared", bounds));
    sqlite3_busy_timeout(db->get(), kReaderBusyMs);
  } else if (write_locked_by_another_process(file)) {
    throw LockedError(
        file.string() +
        ": locked by another program, which is writing it; try again when that program has closed it");
  } else if (wal_bytes > 0) {
    // A .db copied with its -wal (and no -shm): reading it in place would make a -shm beside it
    // (or fail on a read-only medium), so the two are copied into a private folder and read there.
    std::string pattern = (fs::temp_directory_path() / "cariesim-input-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr)
      throw Error(file.string() +
                  ": cannot make a private copy to read it with its -wal: " + std::strerror(errno));
    const fs::path copy_dir = pattern;
    const fs::path copy = copy_dir / "input.db";
    std::error_code ec;
    fs::copy_file(file, copy, ec);
    if (!ec) fs::copy_file(wal, copy.string() + "-wal", ec);
    if (ec) {
      fs::remove_all(copy_dir, ec);
      throw Error(file.string() + ": cannot make a private copy to read it with its -wal: " + ec.message());
    }
    try {
      db.reset(new Database(file.string(), file_uri(copy, "mode=ro"), kFlags, "copy", bounds));
    } catch (...) {
      fs::remove_all(copy_dir, ec);
      throw;
    }
    db->private_copy_ = copy_dir;
  } else {
    // At rest: nothing beside it, nobody writing it. Immutable: no lock, no -wal or -shm made, works
    // on a read-only medium; check_input_unchanged() tells when a writer started meanwhile.
    struct stat st {};
    if (::stat(file.c_str(), &st) != 0) throw Error(file.string() + ": cannot read: " + std::strerror(errno));
    db.reset(new Database(file.string(), file_uri(file, "mode=ro&immutable=1"), kFlags, "immutable", bounds));
    db->immutable_ = true;
    db->identity_ = {static_cast<std::uintmax_t>(st.st_dev), static_cast<std::uintmax_t>(st.st_ino),
                     static_cast<std::uintmax_t>(st.st_size),
                     static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec};
  }
  db->exec("PRAGMA cell_size_check=ON", "cannot turn on SQLite's page checks");
  identify_and_check(*db, schema);
  db->renew_work_budget();
  return db;
}

std::unique_ptr<Database> open_for_append(const fs::path& file, const Schema& schema) {
  require_database_file(file, schema);
  regular_sidecar(file.string() + "-wal", schema.what + "'s -wal");
  regular_sidecar(file.string() + "-shm", schema.what + "'s -shm");
  std::unique_ptr<Database> db(new Database(file.string(), file_uri(file, ""),
                                            SQLITE_OPEN_READWRITE | SQLITE_OPEN_URI, "append",
                                            default_limits(size_or_zero(file))));
  sqlite3_busy_timeout(db->get(), kReaderBusyMs);
  identify_and_check(*db, schema);
  db->renew_work_budget();
  return db;
}

std::unique_ptr<Database> create_database(const fs::path& file) {
  return std::unique_ptr<Database>(new Database(file.string(), file_uri(file, ""),
                                                SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_URI,
                                                "new", {}));
}

// A memory database through a URI (mode=memory): a plain ":memory:" name would become a file named
// ":memory:" in the working folder once it is turned into a file: URI.
std::unique_ptr<Database> create_memory_database(const std::string& name) {
  return std::unique_ptr<Database>(new Database(name, "file:cariesim-memory?mode=memory",
                                                SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_URI,
                                                "memory", {}));
}

// ---------------------------------------------------------------------------------------------------
// Statement

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

int Statement::type(int column) const { return sqlite3_column_type(stmt_, column); }

std::string_view type_name(int sqlite_type) {
  switch (sqlite_type) {
    case SQLITE_INTEGER:
      return "INTEGER";
    case SQLITE_FLOAT:
      return "REAL";
    case SQLITE_TEXT:
      return "TEXT";
    case SQLITE_BLOB:
      return "BLOB";
    default:
      return "NULL";
  }
}

}  // namespace cariesim::io
