// StudyRun (docs/training.md): the trial sequence of one participant, the answers, and the study
// database (study_schema.hpp). A trial's row is committed when it begins (ended_at NULL) and
// completed with its answers and scores in one transaction when it ends.

#include "cariesim/training/run.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <thread>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/json.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/io/sqlite.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/record/recorder.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/training/course.hpp"
#include "training/scores.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace fs = std::filesystem;
using io::Database;
using io::Statement;

struct StudyRun::Db {
  std::unique_ptr<Database> owner;
  Database& db() { return *owner; }
};

namespace {

// A name that becomes part of the recordings' file names (participant, study): the one rule of
// valid_identifier (course.hpp), so no path can be built from anything else.
void check_name(std::string_view what, const std::string& value, std::string_view example) {
  if (value.empty()) throw Error(fmt::format("{}: required{}", what, example));
  if (!valid_identifier(value))
    throw Error(fmt::format("{} '{}': not a valid name ({})", what, value, kIdentifierRule));
}

// Creates `file` empty and owner-only when it does not exist (SQLite then fills it, and gives its -wal
// and -shm files the same mode).
void create_private_file(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd >= 0) ::close(fd);
}

// This machine's name.
std::string host_name() {
  char name[256] = {};
  if (gethostname(name, sizeof(name) - 1) != 0 || name[0] == '\0') return "station";
  return name;
}

// ms SQLite's own busy handler waits inside one attempt; the attempts themselves back off from
// kFirstBackoff, doubling up to kMaxBackoff, until RunOptions::lock_wait has passed.
constexpr int kAttemptBusyMs = 250;
constexpr auto kFirstBackoff = std::chrono::milliseconds(50);
constexpr auto kMaxBackoff = std::chrono::milliseconds(1000);
// Pending files merged per open, and the largest one read (a trial's answers and scores are a few kB).
constexpr std::size_t kMaxPendingFiles = 100000;
constexpr std::uintmax_t kMaxPendingBytes = std::uintmax_t{16} << 20;

// Runs `attempt` until it does not meet another program's lock (io::LockedError), backing off
// between tries; rethrows the last LockedError once `wait_s` seconds have passed.
template <typename Attempt>
void retry_while_locked(double wait_s, Attempt attempt) {
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(wait_s, 0.0));
  auto backoff = std::chrono::duration_cast<std::chrono::steady_clock::duration>(kFirstBackoff);
  for (;;) {
    try {
      attempt();
      return;
    } catch (const io::LockedError&) {
      if (std::chrono::steady_clock::now() + backoff > deadline) throw;
    }
    std::this_thread::sleep_for(backoff);
    backoff = std::min<std::chrono::steady_clock::duration>(backoff * 2, kMaxBackoff);
  }
}

// One write transaction: BEGIN IMMEDIATE (where another writer's lock is met), `body`, COMMIT; any
// failure rolls back and is rethrown (a lock as io::LockedError).
template <typename Body>
void write_transaction(Database& db, const std::string& what, Body body) {
  db.exec("BEGIN IMMEDIATE", "cannot begin " + what);
  try {
    body();
    db.exec("COMMIT", "cannot commit " + what);
  } catch (...) {
    db.try_exec("ROLLBACK");
    throw;
  }
}

// A new study database: WAL (a crash loses nothing committed), the id, the schema, the version row.
void create_study_database(Database& db) {
  {
    Statement mode(db, "PRAGMA journal_mode=WAL");
    if (mode.step() != SQLITE_ROW || mode.text(0) != "wal")
      db.fail("cannot switch to WAL mode (the file system may not support it)");
  }
  write_transaction(db, "creating the study database", [&] {
    db.exec("PRAGMA application_id=" + std::to_string(kStudyApplicationId), "cannot set the application id");
    db.exec(std::string(kStudySchemaSql), "cannot create the study tables");
    Statement version(db, "INSERT INTO schema_version (version, application) VALUES (?, ?)");
    version.bind(0, int64_t{kStudySchemaVersion});
    version.bind(1, std::string(kStudyApplication));
    if (version.step() != SQLITE_DONE) db.fail("cannot write the schema version");
  });
}

// The study database: created with the schema when there is no file (or an empty one); an existing
// one opened through the defensive opener, checked to hold exactly the study schema of our version
// (a trigger planted in it would rewrite later scores), retried while another program holds it.
std::unique_ptr<Database> open_study_database(const fs::path& file, double lock_wait) {
  std::error_code ec;
  const bool exists = fs::exists(file, ec);
  if (!exists || (fs::is_regular_file(file, ec) && fs::file_size(file, ec) == 0)) {
    std::unique_ptr<Database> db = io::create_database(file);
    sqlite3_busy_timeout(db->get(), kAttemptBusyMs);
    retry_while_locked(lock_wait, [&] { create_study_database(*db); });
    return db;
  }
  std::unique_ptr<Database> db;
  retry_while_locked(lock_wait, [&] { db = io::open_for_append(file, study_schema(true)); });
  sqlite3_busy_timeout(db->get(), kAttemptBusyMs);
  retry_while_locked(lock_wait, [&] {
    Statement mode(*db, "PRAGMA journal_mode=WAL");
    if (mode.step() != SQLITE_ROW) db->fail("cannot switch to WAL mode");
  });
  // A version 1 database gets the study sources' tables (its earlier trials stay as they were).
  retry_while_locked(lock_wait, [&] {
    write_transaction(*db, "adding the study sources' tables", [&] {
      if (study_schema_version(*db) >= kStudySchemaVersion) return;
      db->exec(std::string(kStudySourcesSql), "cannot add the study sources' tables");
      db->exec("UPDATE schema_version SET version = " + std::to_string(kStudySchemaVersion),
               "cannot write the schema version");
    });
  });
  return db;
}

// "0123456789abcdef": a 64-bit hash as 16 hex digits (as recordings store scene hashes).
std::string hex16(uint64_t hash) { return fmt::format("{:016x}", hash); }

// The row of the study's text in `studies` (added when no row holds this text).
int64_t study_row(Database& db, const Study& study) {
  {
    Statement find(db, "SELECT id FROM studies WHERE hash = ? AND yaml = ?");
    find.bind(0, hex16(study.source_hash));
    find.bind(1, study.source);
    const int rc = find.step();
    if (rc == SQLITE_ROW) return find.integer(0);
    if (rc != SQLITE_DONE) db.fail("cannot read the studies");
  }
  Statement insert(db, "INSERT INTO studies (name, origin, hash, yaml) VALUES (?, ?, ?, ?)");
  insert.bind(0, study.name);
  insert.bind(1, study.origin);
  insert.bind(2, hex16(study.source_hash));
  insert.bind(3, study.source);
  if (insert.step() != SQLITE_DONE) db.fail("cannot write the study's text");
  return sqlite3_last_insert_rowid(db.get());
}

// The `--set` overrides as trial_sources.overrides: a JSON array of {"key", "value"}.
std::string overrides_json(const std::vector<SceneOverride>& overrides) {
  io::JsonWriter w;
  w.begin_array();
  for (const SceneOverride& o : overrides)
    w.begin_object().field("key", o.key).field("value", o.value).end_object();
  w.end_array();
  return w.str();
}

// What a trial's end writes: the trial row's identity (checked again when merged later) and its
// results.
struct TrialWrite {
  int64_t row = 0;
  std::string station, participant, study, started_at;
  int64_t trial = 0;
  int64_t seed = 0;
  std::string ended_at, recording, answers_json, scores_json;
  std::vector<Score> scores;
  std::string scene_hash;  // the recording's scene hash (16 hex digits); empty without a recording
};

// The results into the trial's row and the scores table (inside the caller's transaction).
void write_results(Database& db, const TrialWrite& w) {
  Statement update(
      db,
      "UPDATE trials SET ended_at = ?, recording = NULLIF(?, ''), answers = ?, scores = ?, seed = ? WHERE id = ?");
  update.bind(0, w.ended_at);
  update.bind(1, w.recording);
  update.bind(2, w.answers_json);
  update.bind(3, w.scores_json);
  update.bind(4, w.seed);  // a trainee's trial row holds kSeedNotWritten until now
  update.bind(5, w.row);
  if (update.step() != SQLITE_DONE) db.fail("cannot write the trial's answers and scores");
  Statement source(db, "UPDATE trial_sources SET scene_hash = NULLIF(?, '') WHERE trial_id = ?");
  source.bind(0, w.scene_hash);
  source.bind(1, w.row);
  if (source.step() != SQLITE_DONE) db.fail("cannot write the trial's scene hash");
  Statement insert(db, "INSERT INTO scores (trial_id, name, level, value, unit) VALUES (?, ?, ?, ?, ?)");
  for (const Score& s : w.scores) {
    insert.reset();
    insert.bind(0, w.row);
    insert.bind(1, s.name);
    insert.bind(2, s.level);
    insert.bind(3, s.value);
    insert.bind(4, s.unit);
    if (insert.step() != SQLITE_DONE) db.fail(fmt::format("cannot write the score {}", s.name));
  }
}

// The pending file of a trial whose results could not be written: JSON, numbers that must read
// back exactly as text (shortest round-trip form), written to a temporary name, synced and renamed.
fs::path write_pending(const fs::path& database, const TrialWrite& w) {
  io::JsonWriter j;
  j.begin_object();
  j.field("format", 1).field("row", static_cast<long long>(w.row)).field("station", w.station);
  j.field("participant", w.participant).field("study", w.study);
  j.field("trial", static_cast<long long>(w.trial)).field("seed", static_cast<long long>(w.seed));
  j.field("started_at", w.started_at).field("ended_at", w.ended_at).field("recording", w.recording);
  j.field("answers", w.answers_json).field("scores_json", w.scores_json).field("scene_hash", w.scene_hash);
  j.key("scores").begin_array();
  for (const Score& s : w.scores) {
    j.begin_object().field("name", s.name).field("level", s.level);
    j.field("value", fmt::format("{}", s.value)).field("unit", s.unit).end_object();
  }
  j.end_array().end_object();
  const std::string text = j.str() + "\n";

  const fs::path dir = pending_folder(database);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    throw Error(
        fmt::format("{}: cannot create the folder for pending results: {}", dir.string(), ec.message()));
  const fs::path target = dir / fmt::format("trial-{}.json", w.row);
  const fs::path temporary = dir / fmt::format(".trial-{}.json.{}", w.row, ::getpid());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(fmt::format("{}: cannot write: {}", temporary.string(), std::strerror(errno)));
  std::size_t done = 0;
  bool ok = true;
  while (ok && done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    ok = n > 0;
    if (ok) done += static_cast<std::size_t>(n);
  }
  ok = ok && ::fsync(fd) == 0;
  ok = ::close(fd) == 0 && ok;
  if (!ok || std::rename(temporary.c_str(), target.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    fs::remove(temporary, ec);
    throw Error(fmt::format("{}: cannot write the pending results: {}", target.string(), why));
  }
  return target;
}

// A pending file read back (as hostile as any input: strict fields, bounded size).
TrialWrite read_pending(const fs::path& file) {
  const std::string text = io::read_file(file, "pending trial results", kMaxPendingBytes);
  YAML::Node node;
  try {
    node = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error(fmt::format("{}: not a pending trial result: {}", file.string(), e.what()));
  }
  const io::Reader r(file.string());
  const io::Fields f(r, node, "",
                     {"format", "row", "station", "participant", "study", "trial", "seed", "started_at",
                      "ended_at", "recording", "answers", "scores_json", "scores", "scene_hash"});
  if (r.integer_in(f.require("format"), "format", 1, 1) != 1) r.fail(node, "format", "expected 1");
  TrialWrite w;
  w.row = r.integer_in(f.require("row"), "row", 1, std::numeric_limits<int64_t>::max());
  w.station = r.text(f.require("station"), "station");
  w.participant = r.text(f.require("participant"), "participant");
  w.study = r.text(f.require("study"), "study");
  w.trial = r.integer_in(f.require("trial"), "trial", 1, std::numeric_limits<int64_t>::max());
  w.seed = r.integer_in(f.require("seed"), "seed", 0, std::numeric_limits<int64_t>::max());
  w.started_at = r.text(f.require("started_at"), "started_at");
  w.ended_at = r.text(f.require("ended_at"), "ended_at");
  w.recording = r.text(f.require("recording"), "recording");
  w.answers_json = r.text(f.require("answers"), "answers");
  w.scores_json = r.text(f.require("scores_json"), "scores_json");
  if (const YAML::Node n = f.get("scene_hash"); n.IsDefined()) {
    w.scene_hash = r.text(n, "scene_hash");
    if (!w.scene_hash.empty() && (w.scene_hash.size() != 16 ||
                                  w.scene_hash.find_first_not_of("0123456789abcdef") != std::string::npos))
      r.fail(n, "scene_hash", "expected 16 hex digits");
  }
  const YAML::Node scores = f.require("scores");
  r.require_sequence(scores, "scores");
  for (std::size_t i = 0; i < scores.size(); ++i) {
    const std::string path = io::indexed("scores", i);
    const io::Fields sf(r, scores[i], path, {"name", "level", "value", "unit"});
    Score s;
    s.name = r.text(sf.require("name"), sf.sub("name"));
    s.level = r.text(sf.require("level"), sf.sub("level"));
    const std::string value = r.text(sf.require("value"), sf.sub("value"));
    const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), s.value);
    if (ec != std::errc() || end != value.data() + value.size() || !std::isfinite(s.value))
      r.fail(sf.require("value"), sf.sub("value"), "expected a finite number");
    s.unit = r.text(sf.require("unit"), sf.sub("unit"));
    w.scores.push_back(std::move(s));
  }
  return w;
}

// Merges the pending results beside the database, oldest row first: each one whose trial row is
// there, unfinished and the same trial (station, participant, study, number, seed, start) is written
// in one transaction and its file removed; one already merged (the row has ended) is removed; one
// that cannot be read or does not match stays, with a warning. Returns false when the database is
// still locked (the rest wait for the next time).
bool merge_pending(Database& db, const fs::path& database, double lock_wait) {
  const fs::path dir = pending_folder(database);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return true;
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (files.size() >= kMaxPendingFiles) break;
    const std::string name = e.path().filename().string();
    if (name.starts_with("trial-") && name.ends_with(".json")) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    TrialWrite w;
    try {
      w = read_pending(file);
    } catch (const Error& e) {
      spdlog::warn("{} (left in place, not merged)", e.what());
      continue;
    }
    bool merged = false;
    try {
      retry_while_locked(lock_wait, [&] {
        write_transaction(db, "merging pending results", [&] {
          Statement row(db,
                        "SELECT station, participant, study, trial, seed, started_at, ended_at FROM trials "
                        "WHERE id = ?");
          row.bind(0, w.row);
          const int rc = row.step();
          if (rc != SQLITE_ROW && rc != SQLITE_DONE) db.fail("cannot read trial " + std::to_string(w.row));
          const bool same = rc == SQLITE_ROW && row.text(0) == w.station && row.text(1) == w.participant &&
                            row.text(2) == w.study && row.integer(3) == w.trial &&
                            (row.integer(4) == w.seed || row.integer(4) == kSeedNotWritten) &&
                            row.text(5) == w.started_at;
          if (!same) {
            spdlog::warn("{}: trial row {} of {} is not the trial these results belong to (left in place)",
                         file.string(), w.row, database.string());
            return;
          }
          if (!row.is_null(6)) {
            merged = true;  // written before; the file outlived the commit
            return;
          }
          write_results(db, w);
          merged = true;
        });
      });
    } catch (const io::LockedError&) {
      return false;
    }
    if (merged) fs::remove(file, ec);
  }
  return true;
}

// The answers of a trial as trials.answers (docs/training.md, "the study database").
std::string answers_json(const TrialSetup& setup, const TrialAnswers& a,
                         const std::vector<MarkJudgement>& judged) {
  io::JsonWriter w;
  w.begin_object();
  switch (setup.kind) {
    case StudyKind::Tuning:
      w.key("levels").begin_array();
      for (const Grade g : setup.levels) w.value(grade_name(g));
      w.end_array();
      w.key("start").begin_object();
      for (const TunedParameter& p : setup.parameters) w.field(p.name, p.start);
      w.end_object();
      w.key("tuned").begin_object();
      for (const auto& [level, values] : a.tuned) {
        w.key(level).begin_object();
        for (const auto& [name, value] : values) w.field(name, value);
        w.end_object();
      }
      w.end_object();
      w.key("confirmed_at").begin_object();
      for (const auto& [level, t] : a.confirmed_at) w.field(level, t);
      w.end_object();
      break;
    case StudyKind::Boundary:
      w.key("cubes").begin_array();
      for (const std::string& c : setup.cubes) w.value(c);
      w.end_array();
      w.key("named").begin_array();
      for (const std::string& s : a.shapes) s.empty() ? w.null() : w.value(s);
      w.end_array();
      w.key("hidden").begin_array();
      for (const std::string& s : setup.truth.shapes) w.value(s);
      w.end_array();
      break;
    case StudyKind::Diagnosis:
      w.key("lesions").begin_array();
      for (const CaseLesion& l : setup.truth.lesions) {
        w.begin_object().field("site", l.site).field("severity", grade_name(l.severity));
        w.field("size", l.size).field("width", l.width).field("depth", l.depth);
        w.field("shape", lesion_kind_name(l.shape));
        w.key("offset").begin_array().value(l.offset[0]).value(l.offset[1]).end_array().end_object();
      }
      w.end_array();
      w.key("marks").begin_array();
      for (std::size_t i = 0; i < a.marks.size(); ++i) {
        const Mark& m = a.marks[i];
        w.begin_object().field("t", m.t).field("grade", grade_name(m.grade)).field("contact", m.contact);
        w.key("tip").begin_array().value(m.tip.x()).value(m.tip.y()).value(m.tip.z()).end_array();
        if (i < judged.size()) {
          w.key("lesion");
          judged[i].lesion >= 0 ? w.value(judged[i].lesion + 1) : w.null();
          w.field("distance", judged[i].distance).field("first", judged[i].first);
        }
        w.end_object();
      }
      w.end_array();
      w.key("ended_at");
      a.ended_at ? w.value(*a.ended_at) : w.null();
      break;
  }
  w.end_object();
  return w.str();
}

// The scores as trials.scores: name -> value (level ""), or name -> {level -> value}; a (name, level)
// that occurs more than once (time_to_detection of two lesions of one severity) maps to an array.
std::string scores_json(const std::vector<Score>& scores) {
  // Group by name, then level, keeping the order of first appearance.
  std::vector<std::pair<std::string, std::vector<std::pair<std::string, std::vector<double>>>>> groups;
  for (const Score& s : scores) {
    auto g = std::find_if(groups.begin(), groups.end(), [&](const auto& x) { return x.first == s.name; });
    if (g == groups.end()) g = groups.insert(groups.end(), {s.name, {}});
    auto l =
        std::find_if(g->second.begin(), g->second.end(), [&](const auto& x) { return x.first == s.level; });
    if (l == g->second.end()) l = g->second.insert(g->second.end(), {s.level, {}});
    l->second.push_back(s.value);
  }
  io::JsonWriter w;
  const auto values = [&](const std::vector<double>& v) {
    if (v.size() == 1) {
      w.value(v.front());
      return;
    }
    w.begin_array();
    for (const double x : v) w.value(x);
    w.end_array();
  };
  w.begin_object();
  for (const auto& [name, levels] : groups) {
    w.key(name);
    if (levels.size() == 1 && levels.front().first.empty()) {
      values(levels.front().second);
      continue;
    }
    w.begin_object();
    for (const auto& [level, v] : levels) {
      w.key(level);
      values(v);
    }
    w.end_object();
  }
  w.end_object();
  return w.str();
}

}  // namespace

fs::path pending_folder(const fs::path& database) { return fs::path(database.string() + "-pending"); }

StudyRun::StudyRun(Study study, RunOptions options) : study_(std::move(study)), options_(std::move(options)) {
  // The options, then the database, then the seed.
  check_name("participant", options_.participant, " (e.g. --participant P01)");
  check_name("study", study_.name, "");
  if (options_.station.empty()) options_.station = host_name();
  if (options_.recordings.empty()) options_.recordings = options_.database.stem().string() + "-recordings";
  if (options_.database.empty()) throw Error("study database: required (e.g. --out class.db)");
  trial_count_ = options_.trials.value_or(study_.trials);
  if (trial_count_ < 1)
    throw Error(fmt::format("trials: {} is not a trial count (at least 1)", trial_count_));
  std::error_code ec;
  if (const fs::path dir = options_.database.parent_path(); !dir.empty() && !fs::is_directory(dir, ec))
    throw Error(fmt::format("{}: the folder {} does not exist", options_.database.string(), dir.string()));
  if (options_.private_files && !fs::exists(options_.database, ec)) create_private_file(options_.database);
  db_ = std::make_unique<Db>();
  db_->owner = open_study_database(options_.database, options_.lock_wait);
  merge_pending(db_->db(), options_.database, options_.lock_wait);
  if (options_.seed) {
    seed_ = *options_.seed;
  } else if (study_.seed) {
    seed_ = *study_.seed;
  } else {
    std::random_device device;
    seed_ = ((static_cast<uint64_t>(device()) << 32) ^ device()) >> 1;
  }
}

StudyRun::~StudyRun() = default;

void apply_course_seed(const Course& course, RunOptions& options) {
  if (!course.exam_seed) return;
  options.seed = course.exam_seed;
  options.same_cases = true;
}

uint64_t StudyRun::seed_of_trial(int index) const {
  // Each participant's own stream of trials, unless every participant gets the same (an exam).
  return trial_seed(options_.same_cases ? seed_ : participant_seed(seed_, options_.participant), index);
}

TrialSetup StudyRun::trial_setup(int index) const {
  // The trial as begin_trial makes it: its seed's draws, then the run's scene overrides.
  TrialSetup setup = make_trial(study_, index, seed_of_trial(index));
  if (!options_.overrides.empty())
    setup.scene_yaml = override_scene_text(setup.scene_yaml, setup.scene_origin, options_.overrides);
  return setup;
}

const TrialSetup& StudyRun::begin_trial() {
  if (finished()) throw Error(fmt::format("study {}: all {} trials have ended", study_.name, trial_count_));
  if (in_trial_) throw Error(fmt::format("study {}: trial {} has begun already", study_.name, current_ + 1));
  setup_ = trial_setup(current_);
  answers_ = TrialAnswers{};
  answers_.shapes.assign(setup_.cubes.size(), std::string());
  level_ = 0;

  // Pending results first, then the row (ended_at NULL) and its recording's path, in one
  // transaction, retried while another program holds the database.
  Database& db = db_->db();
  merge_pending(db, options_.database, options_.lock_wait);
  started_at_ = utc_now_iso8601();
  try {
    retry_while_locked(options_.lock_wait, [&] {
      write_transaction(db, "a trial", [&] {
        Statement insert(
            db,
            "INSERT INTO trials (station, participant, study, kind, trial, seed, started_at, ended_at,"
            " recording, answers, scores) VALUES (?, ?, ?, ?, ?, ?, ?, NULL, NULL, '{}', '{}')");
        insert.bind(0, options_.station);
        insert.bind(1, options_.participant);
        insert.bind(2, study_.name);
        insert.bind(3, std::string(study_kind_name(study_.kind)));
        insert.bind(4, int64_t{current_ + 1});
        // In trainee mode the seed (it rebuilds the case) waits for the trial's end.
        insert.bind(5, options_.hide_case_while_running ? kSeedNotWritten : static_cast<int64_t>(setup_.seed));
        insert.bind(6, started_at_);
        if (insert.step() != SQLITE_DONE) db.fail("cannot write the trial row");
        row_ = sqlite3_last_insert_rowid(db.get());
        // STUDY-PARTICIPANT-ROW.db, with -2, -3, ... when a file of that name is left from a database
        // that was deleted (row ids then start over).
        const fs::path base = options_.database.parent_path();
        fs::path relative;
        for (int n = 1;; ++n) {
          const std::string suffix = n == 1 ? "" : fmt::format("-{}", n);
          relative = options_.recordings /
                     fmt::format("{}-{}-{}{}.db", study_.name, options_.participant, row_, suffix);
          recording_path_ =
              fs::absolute(relative.is_absolute() ? relative : base / relative).lexically_normal();
          std::error_code exists_ec;
          if (!fs::exists(recording_path_, exists_ec)) break;
        }
        Statement update(db, "UPDATE trials SET recording = ? WHERE id = ?");
        update.bind(0, relative.is_absolute() ? relative.string() : relative.lexically_normal().string());
        update.bind(1, row_);
        if (update.step() != SQLITE_DONE) db.fail("cannot write the trial's recording path");
        // What rebuilds the trial with its seed: the study's text and the overrides.
        Statement source(db, "INSERT INTO trial_sources (trial_id, study_id, overrides) VALUES (?, ?, ?)");
        source.bind(0, row_);
        source.bind(1, study_row(db, study_));
        source.bind(2, overrides_json(options_.overrides));
        if (source.step() != SQLITE_DONE) db.fail("cannot write the trial's study source");
      });
    });
  } catch (const io::LockedError& e) {
    throw Error(fmt::format("{} (for {} s; the trial did not begin)", e.what(), options_.lock_wait));
  }
  if (options_.private_files) {
    create_study_folder(recording_path_.parent_path());
  } else {
    std::error_code ec;
    fs::create_directories(recording_path_.parent_path(), ec);
    if (ec)
      throw Error(fmt::format("{}: cannot create the recordings folder: {}",
                              recording_path_.parent_path().string(), ec.message()));
  }
  in_trial_ = true;
  return setup_;
}

std::optional<Grade> StudyRun::current_level() const {
  if (!in_trial_ || setup_.kind != StudyKind::Tuning || level_ >= setup_.levels.size()) return std::nullopt;
  return setup_.levels[level_];
}

void StudyRun::confirm_tuning(const std::map<std::string, double>& values, double t) {
  const std::optional<Grade> level = current_level();
  if (!level)
    throw Error(in_trial_ && setup_.kind == StudyKind::Tuning ? "tuning: every level is confirmed"
                                                              : "tuning: no tuning trial in progress");
  // Every slider once, finite and within its range; nothing else.
  for (const auto& [name, value] : values) {
    const auto p = std::find_if(setup_.parameters.begin(), setup_.parameters.end(),
                                [&](const TunedParameter& q) { return q.name == name; });
    if (p == setup_.parameters.end())
      throw Error(fmt::format("tuning: '{}' is not tuned in this study", name));
    if (!std::isfinite(value) || value < p->min || value > p->max)
      throw Error(fmt::format("tuning: {} = {} is outside its slider [{}, {}]", name, value, p->min, p->max));
  }
  for (const TunedParameter& p : setup_.parameters)
    if (!values.contains(p.name))
      throw Error(fmt::format("tuning: no value for {} ({})", p.name, grade_name(*level)));
  if (!std::isfinite(t)) throw Error("tuning: the confirmation time is not finite");
  const std::string key(grade_name(*level));
  answers_.tuned[key] = values;
  answers_.confirmed_at[key] = t;
  ++level_;
}

void StudyRun::name_shape(int cube, const std::string& shape) {
  if (!in_trial_ || setup_.kind != StudyKind::Boundary)
    throw Error("boundary: no boundary trial in progress");
  if (cube < 0 || cube >= static_cast<int>(setup_.cubes.size()))
    throw Error(fmt::format("boundary: cube {} does not exist (0 to {})", cube, setup_.cubes.size() - 1));
  if (std::find(setup_.shape_choices.begin(), setup_.shape_choices.end(), shape) ==
      setup_.shape_choices.end()) {
    std::string names;
    for (const auto& s : setup_.shape_choices) names += (names.empty() ? "" : ", ") + s;
    throw Error(fmt::format("boundary: '{}' is not one of the shapes ({})", shape, names));
  }
  answers_.shapes[static_cast<std::size_t>(cube)] = shape;
}

void StudyRun::mark(const Vec3& tip, Grade grade, double t, bool contact) {
  if (!in_trial_ || setup_.kind != StudyKind::Diagnosis)
    throw Error("diagnosis: no diagnosis trial in progress");
  if (answers_.ended_at) throw Error("diagnosis: the case has ended; no more marks");
  if (!tip.allFinite() || !std::isfinite(t))
    throw Error("diagnosis: a mark needs a finite tip position and time");
  answers_.marks.push_back({tip, grade, t, contact});
}

void StudyRun::end_case(double t) {
  if (!in_trial_ || setup_.kind != StudyKind::Diagnosis)
    throw Error("diagnosis: no diagnosis trial in progress");
  if (!std::isfinite(t)) throw Error("diagnosis: the end time is not finite");
  if (!answers_.ended_at) answers_.ended_at = t;
}

TrialResult StudyRun::end_trial(const fs::path& recording, const Model* model) {
  if (!in_trial_) throw Error(fmt::format("study {}: no trial has begun", study_.name));
  // The recording (optional), the lesions (diagnosis), then the scores.
  std::optional<Recording> rec;
  if (!recording.empty()) rec = load_recording(recording);
  std::vector<ScoredLesion> lesions;
  if (setup_.kind == StudyKind::Diagnosis) {
    std::optional<Model> built;
    if (model == nullptr) {
      built = build_model(setup_.scene());
      model = &*built;
    }
    if (model->lesions.size() != setup_.truth.lesions.size())
      throw Error(fmt::format("study {}: the model has {} lesions, the trial {}", study_.name,
                              model->lesions.size(), setup_.truth.lesions.size()));
    for (std::size_t k = 0; k < model->lesions.size(); ++k) {
      const LesionModel& l = model->lesions[k];
      lesions.push_back(
          {l.shape, setup_.truth.lesions[k].severity, model->defaults.materials[l.material].f_p_star});
    }
  }
  TrialResult result;
  result.row = row_;
  result.index = current_;
  result.seed = setup_.seed;
  result.answers = answers_;
  result.scores = compute_scores(study_, setup_, answers_, rec ? &*rec : nullptr, lesions);
  std::vector<MarkJudgement> judged;
  if (setup_.kind == StudyKind::Diagnosis)
    judged = judge_marks(answers_.marks, lesions, study_.diagnosis.detection_margin);
  result.answers_json = answers_json(setup_, answers_, judged);
  result.scores_json = scores_json(result.scores);

  // The recording's path relative to the database's folder when it lies inside it.
  std::string stored;
  if (!recording.empty()) {
    const fs::path base = fs::absolute(options_.database).parent_path().lexically_normal();
    const fs::path rel = fs::absolute(recording).lexically_normal().lexically_relative(base);
    stored =
        (!rel.empty() && !rel.string().starts_with("..")) ? rel.string() : fs::absolute(recording).string();
    result.recording = stored;
  }

  // Answers, scores, recording and ended_at in one transaction, retried while another program
  // holds the database; when it stays locked, into a pending file beside it (never dropped).
  TrialWrite write;
  write.row = row_;
  write.station = options_.station;
  write.participant = options_.participant;
  write.study = study_.name;
  write.started_at = started_at_;
  write.trial = current_ + 1;
  write.seed = static_cast<int64_t>(setup_.seed);
  write.ended_at = utc_now_iso8601();
  write.recording = stored;
  write.answers_json = result.answers_json;
  write.scores_json = result.scores_json;
  write.scores = result.scores;
  if (rec) write.scene_hash = hex16(rec->info.scene_hash);
  Database& db = db_->db();
  try {
    retry_while_locked(options_.lock_wait, [&] {
      write_transaction(db, "the trial's scores", [&] { write_results(db, write); });
    });
  } catch (const io::LockedError& e) {
    result.pending = write_pending(options_.database, write);
    spdlog::warn("{} (for {} s): trial {}'s answers and scores are kept in {} until it can be written",
                 e.what(), options_.lock_wait, current_ + 1, result.pending.string());
  }
  in_trial_ = false;
  ++current_;
  return result;
}

void StudyRun::abandon_trial(const std::string& reason) {
  if (!in_trial_) throw Error(fmt::format("study {}: no trial has begun", study_.name));
  // The reason and the seed into the row (ended_at stays NULL); a failure here is only logged.
  if (!reason.empty() || options_.hide_case_while_running) {
    try {
      io::JsonWriter w;
      w.begin_object();
      if (!reason.empty()) w.field("error", reason);
      w.end_object();
      Database& db = db_->db();
      Statement update(db, reason.empty() ? "UPDATE trials SET seed = ? WHERE id = ?"
                                          : "UPDATE trials SET seed = ?, answers = ? WHERE id = ?");
      update.bind(0, static_cast<int64_t>(setup_.seed));
      if (!reason.empty()) update.bind(1, w.str());
      update.bind(reason.empty() ? 1 : 2, row_);
      if (update.step() != SQLITE_DONE) db.fail("cannot note why the trial was abandoned");
    } catch (const Error& e) {
      spdlog::error("study {}: {}", study_.name, e.what());
    }
  }
  in_trial_ = false;
  ++current_;
}

void create_study_folder(const fs::path& folder) {
  // The parents as they come, then the folder itself created 0700 (no moment with a wider mode).
  std::error_code ec;
  if (fs::is_directory(folder, ec)) return;
  if (const fs::path parent = folder.parent_path(); !parent.empty()) {
    fs::create_directories(parent, ec);
    if (ec) throw Error(fmt::format("{}: cannot create the folder: {}", parent.string(), ec.message()));
  }
  if (::mkdir(folder.c_str(), 0700) != 0 && errno != EEXIST)
    throw Error(fmt::format("{}: cannot create the folder: {}", folder.string(), std::strerror(errno)));
  if (!fs::is_directory(folder, ec))
    throw Error(fmt::format("{}: exists and is not a folder", folder.string()));
}

}  // namespace cariesim::training
