// Reading recordings back: load_recording (everything into memory) and export_recording_csv (streamed
// row by row, so a long session exports without holding it in memory).
#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <memory>

#include "cariesim/common/error.hpp"
#include "cariesim/io/sqlite.hpp"
#include "cariesim/io/staged_folder.hpp"
#include "cariesim/record/recorder.hpp"
#include "record/schema.hpp"

namespace cariesim {

namespace {

namespace fs = std::filesystem;
using io::Database;
using io::Statement;

// SQLite's last message on `db`, and what to do when it says the file is damaged: the usual cause is
// a `.db` copied without its `-wal` file while the recorder was copying the WAL into it (a checkpoint;
// docs/records.md). The original, read with its `-wal` beside it, is whole.
std::string reason(const Database& db) {
  std::string text = db.message();
  if ((sqlite3_errcode(db.get()) & 0xff) == SQLITE_CORRUPT)
    text +=
        "; the file is damaged: a .db copied without its -wal file while it was being recorded can "
        "be, so copy the two together or read the original";
  return text;
}

// Throws "file: what: reason" (see reason()).
[[noreturn]] void fail_reading(const Database& db, const std::string& what) {
  throw Error(db.file() + ": " + what + ": " + reason(db));
}

// Opens a recording read-only through the defensive opener (io/sqlite.hpp): exactly the recording
// schema, none of the file's own SQL, bounded work, nothing made beside the file. A recorder killed
// mid-session left its -wal and -shm, through which the file is read whole.
std::unique_ptr<Database> open_recording(const fs::path& file, int& version) {
  std::unique_ptr<Database> db = io::open_input(file, record::recording_schema());
  Statement check(*db, "SELECT version FROM schema_version");
  if (check.step() != SQLITE_ROW) fail_reading(*db, "cannot read the schema version");
  version = static_cast<int>(check.integer(0));
  return db;
}

// The session row and the recorder settings stored with it.
void read_session_row(Database& db, Recording& out) {
  Statement row(db,
                "SELECT scene, scene_hash, device, rate_hz, version, parameters, started_at, ended_at,"
                " batch_seconds, soft_tissue_threshold FROM session WHERE id = 1");
  if (row.step() != SQLITE_ROW) throw Error(db.file() + ": the session row is missing");
  SessionInfo& info = out.info;
  info.scene = row.text(0);
  info.scene_hash = record::hash_from_hex(row.text(1), db.file());
  info.device = row.text(2);
  info.rate_hz = row.real(3);
  info.version = row.text(4);
  info.parameters = row.text(5);
  info.started_at = row.text(6);
  info.ended_at = row.text(7);
  out.batch_seconds = row.real(8);
  out.soft_tissue_threshold = row.real(9);
}

RecordedEvent read_event(const Statement& row) {
  RecordedEvent e;
  e.t = row.real(0);
  e.kind = row.text(1);
  e.detail = row.text(2);
  e.value = row.real(3);
  e.lesion = static_cast<int>(row.integer(4));
  e.duration = row.real(5);
  return e;
}

constexpr const char* kSelectEvents =
    "SELECT t, kind, detail, value, lesion, duration FROM events ORDER BY t, id";

// Text fields are quoted when they hold a separator, a quote or a line break (RFC 4180).
void put_text(fmt::memory_buffer& out, const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) {
    out.append(text);
    return;
  }
  out.push_back('"');
  for (const char c : text) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
}

// Numbers in their shortest exact form (they read back bit for bit); NaN as "nan".
template <typename T>
void put_number(fmt::memory_buffer& out, T value) {
  fmt::format_to(std::back_inserter(out), "{}", value);
}

// A CSV file written through a buffer; every failure names the file.
class CsvFile {
 public:
  explicit CsvFile(const fs::path& path) : path_(path), file_(std::fopen(path.c_str(), "wb")) {
    if (!file_) throw Error(path.string() + ": cannot write");
  }
  ~CsvFile() {
    if (file_) std::fclose(file_);
  }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;
  fmt::memory_buffer& buffer() { return buffer_; }
  // Ends the row; flushes the buffer when it is large.
  void end_row() {
    buffer_.push_back('\n');
    if (buffer_.size() > (1u << 16)) flush();
  }
  void flush() {
    if (buffer_.size() > 0 && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
      throw Error(path_.string() + ": write failed");
    buffer_.clear();
  }
  void close() {
    flush();
    const int rc = std::fclose(file_);
    file_ = nullptr;
    if (rc != 0) throw Error(path_.string() + ": write failed");
  }

 private:
  fs::path path_;
  std::FILE* file_;
  fmt::memory_buffer buffer_;
};

void write_header(CsvFile& csv, const char* const* names, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    if (i > 0) csv.buffer().push_back(',');
    csv.buffer().append(std::string_view(names[i]));
  }
  csv.end_row();
}

// One samples.csv row: the table's columns with the state by name.
void put_sample(fmt::memory_buffer& b, const ServoSample& s) {
  const auto next = [&b](auto value) {
    b.push_back(',');
    put_number(b, value);
  };
  put_number(b, s.t);
  for (const Pose* pose : {&s.haptic, &s.graphic}) {
    for (int k = 0; k < 3; ++k) next(pose->p[k]);
    next(pose->q.w());
    next(pose->q.x());
    next(pose->q.y());
    next(pose->q.z());
  }
  for (int k = 0; k < 3; ++k) next(s.force[k]);
  for (int k = 0; k < 3; ++k) next(s.torque[k]);
  b.push_back(',');
  b.append(std::string_view(state_name(s.state)));
  next(s.depth);
  next(static_cast<unsigned>(s.contacts));
  next(s.step_us);
  next(static_cast<int>(s.lesion));
  next(s.soft_tissue_force);
  next(s.step_flags);
  next(s.safety_flags);
  next(s.overrun ? 1 : 0);
  next(s.buttons);
}

// One trajectory.csv row: time and haptic pose.
void put_trajectory_row(fmt::memory_buffer& b, double t, const Pose& h) {
  const auto next = [&b](double value) {
    b.push_back(',');
    put_number(b, value);
  };
  put_number(b, t);
  for (int k = 0; k < 3; ++k) next(h.p[k]);
  next(h.q.w());
  next(h.q.x());
  next(h.q.y());
  next(h.q.z());
}

}  // namespace

namespace record {

std::unique_ptr<Database> open_recording(const fs::path& file) {
  int version = 0;
  return cariesim::open_recording(file, version);
}

void read_session(Database& db, Recording& out) { cariesim::read_session_row(db, out); }

std::vector<RecordedEvent> read_events(Database& db, std::size_t max) {
  std::vector<RecordedEvent> out;
  Statement events(db, kSelectEvents);
  int rc = SQLITE_ROW;
  while (out.size() < max && (rc = events.step()) == SQLITE_ROW) out.push_back(read_event(events));
  if (rc != SQLITE_ROW && rc != SQLITE_DONE) fail_reading(db, "cannot read the events");
  return out;
}

}  // namespace record

Recording load_recording(const fs::path& file) {
  Recording out;
  const std::unique_ptr<Database> db = open_recording(file, out.schema_version);
  read_session_row(*db, out);
  // One read transaction, so a recorder still writing cannot change the file between the queries.
  db->exec("BEGIN", "cannot begin reading");
  {
    Statement count(*db, "SELECT count(*) FROM samples");
    if (count.step() == SQLITE_ROW) out.samples.reserve(static_cast<std::size_t>(count.integer(0)));
    Statement samples(*db, record::select_samples_sql());
    int rc = SQLITE_ROW;
    while ((rc = samples.step()) == SQLITE_ROW) out.samples.push_back(record::read_sample(samples));
    if (rc != SQLITE_DONE) fail_reading(*db, "cannot read the samples");
    Statement events(*db, kSelectEvents);
    while ((rc = events.step()) == SQLITE_ROW) out.events.push_back(read_event(events));
    if (rc != SQLITE_DONE) fail_reading(*db, "cannot read the events");
  }
  db->exec("COMMIT", "cannot end reading");
  db->check_input_unchanged();
  return out;
}

// Everything is written into a staging folder beside `dir` and moved into `dir` only when complete,
// so a failed export leaves an earlier one in `dir` as it was.
ExportSummary export_recording_csv(const fs::path& file, const fs::path& out_dir) {
  int version = 0;
  const std::unique_ptr<Database> db = open_recording(file, version);
  Recording session;
  read_session_row(*db, session);
  io::StagedFolder staged(out_dir, "export");
  const fs::path& dir = staged.staging();
  ExportSummary summary;
  db->exec("BEGIN", "cannot begin reading");

  // session.csv: a header and one row.
  {
    CsvFile csv(dir / "session.csv");
    fmt::memory_buffer& b = csv.buffer();
    b.append(
        std::string_view("scene,scene_hash,device,rate_hz,version,parameters,started_at,ended_at,batch_"
                         "seconds,soft_tissue_threshold"));
    csv.end_row();
    const SessionInfo& info = session.info;
    put_text(b, info.scene);
    b.push_back(',');
    b.append(record::hash_to_hex(info.scene_hash));
    b.push_back(',');
    put_text(b, info.device);
    b.push_back(',');
    put_number(b, info.rate_hz);
    b.push_back(',');
    put_text(b, info.version);
    b.push_back(',');
    put_text(b, info.parameters);
    b.push_back(',');
    put_text(b, info.started_at);
    b.push_back(',');
    put_text(b, info.ended_at);
    b.push_back(',');
    put_number(b, session.batch_seconds);
    b.push_back(',');
    put_number(b, session.soft_tissue_threshold);
    csv.end_row();
    csv.close();
    summary.files.push_back(dir / "session.csv");
  }

  // samples.csv and trajectory.csv in one pass; the trajectory keeps the rows `cariesim sim` accepts
  // (finite pose, non-zero quaternion, increasing time).
  {
    CsvFile samples(dir / "samples.csv");
    CsvFile trajectory(dir / "trajectory.csv");
    write_header(samples, record::kSampleColumns.data(), record::kSampleColumns.size());
    trajectory.buffer().append(std::string_view("t,px,py,pz,qw,qx,qy,qz"));
    trajectory.end_row();
    Statement rows(*db, record::select_samples_sql());
    double last_t = -std::numeric_limits<double>::infinity();
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      const ServoSample s = record::read_sample(rows);
      put_sample(samples.buffer(), s);
      samples.end_row();
      ++summary.samples;
      const Pose& h = s.haptic;
      if (std::isfinite(s.t) && s.t > last_t && h.p.allFinite() && h.q.coeffs().allFinite() &&
          h.q.squaredNorm() > 1e-12) {
        put_trajectory_row(trajectory.buffer(), s.t, h);
        trajectory.end_row();
        last_t = s.t;
        ++summary.trajectory_rows;
      }
    }
    if (rc != SQLITE_DONE) fail_reading(*db, "cannot read the samples");
    samples.close();
    trajectory.close();
    summary.files.push_back(dir / "samples.csv");
    summary.files.push_back(dir / "trajectory.csv");
  }

  // events.csv, by start time.
  {
    CsvFile csv(dir / "events.csv");
    write_header(csv, record::kEventColumns.data(), record::kEventColumns.size());
    Statement rows(*db, kSelectEvents);
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      const RecordedEvent e = read_event(rows);
      fmt::memory_buffer& b = csv.buffer();
      put_number(b, e.t);
      b.push_back(',');
      put_text(b, e.kind);
      b.push_back(',');
      put_text(b, e.detail);
      b.push_back(',');
      put_number(b, e.value);
      b.push_back(',');
      put_number(b, e.lesion);
      b.push_back(',');
      put_number(b, e.duration);
      csv.end_row();
      ++summary.events;
    }
    if (rc != SQLITE_DONE) fail_reading(*db, "cannot read the events");
    csv.close();
    summary.files.push_back(dir / "events.csv");
  }
  db->exec("COMMIT", "cannot end reading");
  db->check_input_unchanged();
  staged.publish();
  for (fs::path& f : summary.files) f = staged.target() / f.filename();
  return summary;
}

}  // namespace cariesim
