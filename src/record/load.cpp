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
#include "cariesim/io/csv.hpp"
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

// The column keys of a table as the header row.
template <std::size_t N>
void write_header(io::CsvWriter& csv, const std::array<const char*, N>& names) {
  for (const char* name : names) csv.text(name);
  csv.end_row();
}

// One samples.csv row: the table's columns with the state by name. Numbers in their shortest exact
// form (they read back bit for bit).
void put_sample(io::CsvWriter& csv, const ServoSample& s) {
  csv.number(s.t);
  for (const Pose* pose : {&s.haptic, &s.graphic}) {
    for (int k = 0; k < 3; ++k) csv.number(pose->p[k]);
    csv.number(pose->q.w()).number(pose->q.x()).number(pose->q.y()).number(pose->q.z());
  }
  for (int k = 0; k < 3; ++k) csv.number(s.force[k]);
  for (int k = 0; k < 3; ++k) csv.number(s.torque[k]);
  csv.text(state_name(s.state));
  csv.number(s.depth).integer(s.contacts).number(s.step_us).integer(s.lesion);
  csv.number(s.soft_tissue_force).integer(s.step_flags).integer(s.safety_flags).integer(s.overrun ? 1 : 0);
  csv.integer(s.buttons);
  csv.end_row();
}

// One trajectory.csv row: time and haptic pose.
void put_trajectory_row(io::CsvWriter& csv, double t, const Pose& h) {
  csv.number(t);
  for (int k = 0; k < 3; ++k) csv.number(h.p[k]);
  csv.number(h.q.w()).number(h.q.x()).number(h.q.y()).number(h.q.z());
  csv.end_row();
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
    io::CsvWriter csv(dir / "session.csv");
    csv.header({"scene", "scene_hash", "device", "rate_hz", "version", "parameters", "started_at", "ended_at",
                "batch_seconds", "soft_tissue_threshold"});
    const SessionInfo& info = session.info;
    csv.text(info.scene).text(record::hash_to_hex(info.scene_hash)).text(info.device).number(info.rate_hz);
    csv.text(info.version).text(info.parameters).text(info.started_at).text(info.ended_at);
    csv.number(session.batch_seconds).number(session.soft_tissue_threshold);
    csv.end_row();
    csv.close();
    summary.files.push_back(dir / "session.csv");
  }

  // samples.csv and trajectory.csv in one pass; the trajectory keeps the rows `cariesim sim` accepts
  // (finite pose, non-zero quaternion, increasing time).
  {
    io::CsvWriter samples(dir / "samples.csv");
    io::CsvWriter trajectory(dir / "trajectory.csv");
    write_header(samples, record::kSampleColumns);
    trajectory.header({"t", "px", "py", "pz", "qw", "qx", "qy", "qz"});
    Statement rows(*db, record::select_samples_sql());
    double last_t = -std::numeric_limits<double>::infinity();
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      const ServoSample s = record::read_sample(rows);
      put_sample(samples, s);
      ++summary.samples;
      const Pose& h = s.haptic;
      if (std::isfinite(s.t) && s.t > last_t && h.p.allFinite() && h.q.coeffs().allFinite() &&
          h.q.squaredNorm() > 1e-12) {
        put_trajectory_row(trajectory, s.t, h);
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
    io::CsvWriter csv(dir / "events.csv");
    write_header(csv, record::kEventColumns);
    Statement rows(*db, kSelectEvents);
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      const RecordedEvent e = read_event(rows);
      csv.number(e.t).text(e.kind).text(e.detail).number(e.value).integer(e.lesion).number(e.duration);
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
