#pragma once
// The recording schema (docs/records.md): table definitions, the sample and event columns in their
// table (and CSV) order, and the binding/reading of one sample row.
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cariesim/io/sqlite.hpp"
#include "cariesim/record/recorder.hpp"

namespace cariesim::record {

using io::Database;
using io::Statement;

/// Version of the schema this code writes and reads (the `schema_version` table).
inline constexpr int kSchemaVersion = 1;
/// PRAGMA application_id of a cariesim recording ("CRSM"), so `file` and readers can tell.
inline constexpr int32_t kApplicationId = 0x4352534d;

/// The `samples` columns after `id`, in order (also samples.csv's columns).
inline constexpr std::array<const char*, 31> kSampleColumns = {
    "t",          "h_px",         "h_py",
    "h_pz",       "h_qw",         "h_qx",
    "h_qy",       "h_qz",         "g_px",
    "g_py",       "g_pz",         "g_qw",
    "g_qx",       "g_qy",         "g_qz",
    "fx",         "fy",           "fz",
    "tx",         "ty",           "tz",
    "state",      "depth",        "contacts",
    "step_us",    "lesion",       "soft_tissue_force",
    "step_flags", "safety_flags", "overrun",
    "buttons"};

/// The `events` columns after `id`, in order (also events.csv's columns).
inline constexpr std::array<const char*, 6> kEventColumns = {"t",     "kind",   "detail",
                                                             "value", "lesion", "duration"};

/// What a recording holds, for io::open_input: the application id, the version row (schema_version
/// with application 'cariesim' and version kSchemaVersion) and exactly the tables and index
/// create_schema makes, each with the columns the readers use. A recording is an input from
/// elsewhere: nothing else in it is accepted (docs/records.md).
io::Schema recording_schema();

/// Opens `file` as a recording this code reads (io::open_input with recording_schema(), the version
/// checked); throws cariesim::Error naming the file and the cause.
std::unique_ptr<Database> open_recording(const std::filesystem::path& file);
/// The session row and the recorder settings into `out` (info, batch_seconds, soft_tissue_threshold).
void read_session(Database& db, Recording& out);
/// The first `max` events by start time.
std::vector<RecordedEvent> read_events(Database& db, std::size_t max);

/// Creates every table and writes the version and state-name rows (inside the caller's transaction).
void create_schema(Database& db);

/// "INSERT INTO samples(id, t, ...) VALUES (?, ...)".
std::string insert_sample_sql();
/// "SELECT t, ... FROM samples ORDER BY id".
std::string select_samples_sql();

/// Binds parameter 0 to `id` and 1.. to the sample's fields in kSampleColumns order.
void bind_sample(Statement& insert, int64_t id, const ServoSample& sample);
/// Reads a sample from columns 0.. of a select_samples_sql() row.
ServoSample read_sample(const Statement& row);

/// The session row's scene hash as 16 lowercase hex digits, and back (throws cariesim::Error).
std::string hash_to_hex(uint64_t hash);
uint64_t hash_from_hex(const std::string& hex, const std::string& file);

}  // namespace cariesim::record
