#include "record/schema.hpp"

#include <fmt/format.h>

#include "cariesim/common/error.hpp"

namespace cariesim::record {

namespace {

// Column declarations of the samples table: REAL affinity for measured values (a NaN is stored as
// NULL), INTEGER for codes, counts and bit sets.
bool is_integer_column(const std::string& name) {
  return name == "state" || name == "contacts" || name == "lesion" || name == "step_flags" ||
         name == "safety_flags" || name == "overrun" || name == "buttons";
}

}  // namespace

// Tables, the version row and the state names, in one script.
void create_schema(Database& db) {
  std::string samples = "CREATE TABLE samples (id INTEGER PRIMARY KEY";
  for (const char* column : kSampleColumns)
    samples += fmt::format(", {} {}", column, is_integer_column(column) ? "INTEGER" : "REAL");
  samples += ");";
  const std::string script = fmt::format(
      "CREATE TABLE schema_version (version INTEGER NOT NULL, application TEXT NOT NULL);"
      "INSERT INTO schema_version VALUES ({}, 'cariesim');"
      "CREATE TABLE session (id INTEGER PRIMARY KEY CHECK (id = 1), scene TEXT NOT NULL,"
      " scene_hash TEXT NOT NULL, device TEXT NOT NULL, rate_hz REAL NOT NULL, version TEXT NOT NULL,"
      " parameters TEXT NOT NULL, started_at TEXT NOT NULL, ended_at TEXT,"
      " batch_seconds REAL NOT NULL, soft_tissue_threshold REAL NOT NULL);"
      "CREATE TABLE state_names (code INTEGER PRIMARY KEY, name TEXT NOT NULL UNIQUE);"
      "INSERT INTO state_names VALUES (0, 'free'), (1, 'sliding'), (2, 'inserting'), (3, 'extracting');"
      "{}"
      "CREATE TABLE events (id INTEGER PRIMARY KEY, t REAL, kind TEXT NOT NULL, detail TEXT NOT NULL,"
      " value REAL, lesion INTEGER NOT NULL, duration REAL);"
      "CREATE INDEX events_by_time ON events (t);",
      kSchemaVersion, samples);
  db.exec(script, "cannot create the schema");
}

io::Schema recording_schema() {
  io::Schema schema;
  schema.what = "cariesim recording";
  schema.application_id = kApplicationId;
  schema.known_applications = {{0x43525354, "a cariesim study database"}};
  schema.version_table = "schema_version";
  schema.identify = [](Database& db) {
    Statement check(db, "SELECT version, application FROM schema_version");
    const int rc = check.step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) db.fail("cannot read the schema version");
    if (rc != SQLITE_ROW || check.text(1) != "cariesim")
      throw Error(db.file() + ": not a cariesim recording (schema_version has no cariesim row)");
    const int64_t version = check.integer(0);
    if (version != kSchemaVersion)
      throw Error(db.file() + ": schema version " + std::to_string(version) +
                  " is not supported (this cariesim reads version " + std::to_string(kSchemaVersion) + ")");
  };
  std::vector<std::string> samples = {"id"};
  for (const char* column : kSampleColumns) samples.emplace_back(column);
  std::vector<std::string> events = {"id"};
  for (const char* column : kEventColumns) events.emplace_back(column);
  using Type = io::SchemaObject::Type;
  schema.objects = {
      {Type::Table, "schema_version", "schema_version", {"version", "application"}},
      {Type::Table,
       "session",
       "session",
       {"id", "scene", "scene_hash", "device", "rate_hz", "version", "parameters", "started_at", "ended_at",
        "batch_seconds", "soft_tissue_threshold"}},
      {Type::Table, "state_names", "state_names", {"code", "name"}},
      {Type::Table, "samples", "samples", samples},
      {Type::Table, "events", "events", events},
      {Type::Index, "events_by_time", "events", {}},
  };
  return schema;
}

std::string insert_sample_sql() {
  std::string names = "id";
  std::string marks = "?";
  for (const char* column : kSampleColumns) {
    names += fmt::format(", {}", column);
    marks += ", ?";
  }
  return fmt::format("INSERT INTO samples ({}) VALUES ({})", names, marks);
}

std::string select_samples_sql() {
  std::string names;
  for (const char* column : kSampleColumns) names += names.empty() ? column : fmt::format(", {}", column);
  return fmt::format("SELECT {} FROM samples ORDER BY id", names);
}

// Parameters in kSampleColumns order after the id.
void bind_sample(Statement& insert, int64_t id, const ServoSample& s) {
  int i = 0;
  insert.bind(i++, id);
  insert.bind(i++, s.t);
  for (const Pose* pose : {&s.haptic, &s.graphic}) {
    for (int k = 0; k < 3; ++k) insert.bind(i++, pose->p[k]);
    insert.bind(i++, pose->q.w());
    insert.bind(i++, pose->q.x());
    insert.bind(i++, pose->q.y());
    insert.bind(i++, pose->q.z());
  }
  for (int k = 0; k < 3; ++k) insert.bind(i++, s.force[k]);
  for (int k = 0; k < 3; ++k) insert.bind(i++, s.torque[k]);
  insert.bind(i++, static_cast<int64_t>(s.state));
  insert.bind(i++, static_cast<double>(s.depth));
  insert.bind(i++, static_cast<int64_t>(s.contacts));
  insert.bind(i++, static_cast<double>(s.step_us));
  insert.bind(i++, static_cast<int64_t>(s.lesion));
  insert.bind(i++, static_cast<double>(s.soft_tissue_force));
  insert.bind(i++, static_cast<int64_t>(s.step_flags));
  insert.bind(i++, static_cast<int64_t>(s.safety_flags));
  insert.bind(i++, static_cast<int64_t>(s.overrun ? 1 : 0));
  insert.bind(i++, static_cast<int64_t>(s.buttons));
}

// Columns in kSampleColumns order; codes outside their type's range are clamped to a valid value.
ServoSample read_sample(const Statement& row) {
  ServoSample s;
  int i = 0;
  s.t = row.real(i++);
  for (Pose* pose : {&s.haptic, &s.graphic}) {
    for (int k = 0; k < 3; ++k) pose->p[k] = row.real(i++);
    const double w = row.real(i++);
    const double x = row.real(i++);
    const double y = row.real(i++);
    const double z = row.real(i++);
    pose->q = Quat(w, x, y, z);
  }
  for (int k = 0; k < 3; ++k) s.force[k] = row.real(i++);
  for (int k = 0; k < 3; ++k) s.torque[k] = row.real(i++);
  const int64_t state = row.integer(i++);
  s.state = state >= 0 && state <= 3 ? static_cast<InteractionState>(state) : InteractionState::Free;
  s.depth = static_cast<float>(row.real(i++));
  s.contacts = static_cast<uint16_t>(row.integer(i++));
  s.step_us = static_cast<float>(row.real(i++));
  s.lesion = static_cast<int8_t>(row.integer(i++));
  s.soft_tissue_force = static_cast<float>(row.real(i++));
  s.step_flags = static_cast<uint32_t>(row.integer(i++));
  s.safety_flags = static_cast<uint32_t>(row.integer(i++));
  s.overrun = row.integer(i++) != 0;
  s.buttons = static_cast<uint32_t>(row.integer(i++));
  return s;
}

std::string hash_to_hex(uint64_t hash) { return fmt::format("{:016x}", hash); }

uint64_t hash_from_hex(const std::string& hex, const std::string& file) {
  uint64_t value = 0;
  bool ok = !hex.empty() && hex.size() <= 16;
  for (const char c : hex) {
    int digit = -1;
    if (c >= '0' && c <= '9') digit = c - '0';
    if (c >= 'a' && c <= 'f') digit = c - 'a' + 10;
    if (c >= 'A' && c <= 'F') digit = c - 'A' + 10;
    if (digit < 0) ok = false;
    value = value * 16 + static_cast<uint64_t>(digit < 0 ? 0 : digit);
  }
  if (!ok) throw Error(file + ": session.scene_hash: expected 16 hex digits, got '" + hex + "'");
  return value;
}

}  // namespace cariesim::record
