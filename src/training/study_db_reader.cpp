// Reading study databases (study_schema.hpp) for `cariesim report` and merging the databases of many
// stations: only the columns the schema file names are read, so columns a later writer adds do not
// matter.
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <tuple>

#include "cariesim/common/error.hpp"
#include "cariesim/training/report.hpp"
#include "cariesim/io/sqlite.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace fs = std::filesystem;
using io::Database;
using io::Statement;

namespace {

// The application id as its four characters ("CRST"), or its number when it is not printable.
std::string application_name(int id) {
  std::string name;
  for (int shift = 24; shift >= 0; shift -= 8) {
    const char c = static_cast<char>((static_cast<unsigned>(id) >> shift) & 0xFFU);
    if (c < 0x20 || c > 0x7E) return std::to_string(id);
    name.push_back(c);
  }
  return "\"" + name + "\"";
}

// Opens `file` read-only and checks that it is a study database of this schema version.
std::unique_ptr<Database> open_study_database(const fs::path& file) {
  std::error_code ec;
  if (!fs::exists(file, ec)) throw Error(file.string() + ": no such study database");
  if (fs::is_directory(file, ec)) throw Error(file.string() + ": is a folder, not a study database");
  auto db = std::make_unique<Database>(file, SQLITE_OPEN_READONLY);
  db->exec("PRAGMA busy_timeout=2000", "cannot set the busy timeout");

  // The application id tells a study database from a recording or any other SQLite file; the first
  // read also fails on a file that is not SQLite at all.
  int application_id = 0;
  {
    std::unique_ptr<Statement> pragma;
    try {
      pragma = std::make_unique<Statement>(*db, "PRAGMA application_id");
    } catch (const Error&) {
      throw Error(file.string() + ": not a study database (" + db->message() + ")");
    }
    const int rc = pragma->step();
    if (rc != SQLITE_ROW) throw Error(file.string() + ": not a study database (" + db->message() + ")");
    application_id = static_cast<int>(pragma->integer(0));
  }
  if (application_id != kStudyApplicationId)
    throw Error(file.string() + ": not a study database (application id " + application_name(application_id) +
                (application_id == 0x4352534D ? ", a cariesim session recording" : "") +
                ", a study database has " + application_name(kStudyApplicationId) + ")");

  // The schema version: this reader knows version kStudySchemaVersion only.
  std::unique_ptr<Statement> version;
  try {
    version = std::make_unique<Statement>(*db, "SELECT version FROM schema_version");
  } catch (const Error&) {
    throw Error(file.string() + ": not a study database (" + db->message() + ")");
  }
  if (version->step() != SQLITE_ROW)
    throw Error(file.string() + ": not a study database (schema_version has no row)");
  const std::int64_t v = version->integer(0);
  if (v > kStudySchemaVersion)
    throw Error(file.string() + ": study database schema version " + std::to_string(v) +
                " is newer than this cariesim reads (" + std::to_string(kStudySchemaVersion) +
                "); report it with a newer cariesim");
  if (v != kStudySchemaVersion)
    throw Error(file.string() + ": study database schema version " + std::to_string(v) +
                " is not supported (this cariesim reads version " + std::to_string(kStudySchemaVersion) +
                ")");
  return db;
}

// "FILE#id": where a trial row came from.
std::string row_name(const StudyTrial& t) { return t.file + "#" + std::to_string(t.id); }

// Two copies of one trial agree when they hold the same end time and the same scores.
bool same_content(const StudyTrial& a, const StudyTrial& b) {
  if (a.ended_at != b.ended_at || a.scores.size() != b.scores.size()) return false;
  auto key = [](const TrialScore& s) { return std::tie(s.name, s.level, s.value, s.unit); };
  std::vector<TrialScore> x = a.scores, y = b.scores;
  auto less = [&](const TrialScore& l, const TrialScore& r) { return key(l) < key(r); };
  std::sort(x.begin(), x.end(), less);
  std::sort(y.begin(), y.end(), less);
  for (std::size_t i = 0; i < x.size(); ++i)
    if (key(x[i]) != key(y[i])) return false;
  return true;
}

}  // namespace

std::vector<StudyTrial> read_study_database(const fs::path& file) {
  const std::unique_ptr<Database> db = open_study_database(file);
  const std::string name = file.string();
  std::vector<StudyTrial> trials;
  // One read transaction, so a station still writing cannot change the file between the queries.
  db->exec("BEGIN", "cannot begin reading");

  // The trial rows, then their scores.
  std::map<std::int64_t, std::size_t> by_id;
  {
    Statement rows(
        *db,
        "SELECT id, station, participant, study, kind, trial, seed, started_at, ended_at FROM trials"
        " ORDER BY id");
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      StudyTrial t;
      t.file = name;
      t.id = rows.integer(0);
      t.station = rows.text(1);
      t.participant = rows.text(2);
      t.study = rows.text(3);
      t.kind = rows.text(4);
      t.trial = rows.integer(5);
      t.seed = rows.integer(6);
      t.started_at = rows.text(7);
      if (!rows.is_null(8)) t.ended_at = rows.text(8);
      by_id[t.id] = trials.size();
      trials.push_back(std::move(t));
    }
    if (rc != SQLITE_DONE) db->fail("cannot read the trials");
  }
  {
    Statement rows(*db, "SELECT trial_id, name, level, value, unit FROM scores ORDER BY rowid");
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      const std::int64_t trial_id = rows.integer(0);
      const auto it = by_id.find(trial_id);
      if (it == by_id.end())
        throw Error(name + ": scores: a score of trial id " + std::to_string(trial_id) +
                    " that the trials table lacks");
      TrialScore s;
      s.name = rows.text(1);
      s.level = rows.text(2);
      s.value = rows.real(3);
      s.unit = rows.text(4);
      if (!std::isfinite(s.value))
        throw Error(name + ": scores: trial id " + std::to_string(trial_id) + ", score '" + s.name +
                    "': the value is not a finite number");
      trials[it->second].scores.push_back(std::move(s));
    }
    if (rc != SQLITE_DONE) db->fail("cannot read the scores");
  }
  db->exec("COMMIT", "cannot end reading");
  return trials;
}

MergedStudies merge_study_databases(const std::vector<fs::path>& files) {
  MergedStudies merged;
  using Key = std::tuple<std::string, std::string, std::string, std::int64_t, std::int64_t, std::string>;
  std::map<Key, StudyTrial> unique;
  std::vector<Key> order;  // first appearance, for a stable output before sorting
  std::vector<fs::path> seen;

  for (const fs::path& file : files) {
    MergedStudies::Input input;
    input.file = file.string();

    // The same file again (by another name, a link): counted once, reported.
    std::error_code ec;
    for (const fs::path& earlier : seen)
      if (fs::equivalent(earlier, file, ec)) input.same_file_again = true;
    if (input.same_file_again) {
      merged.inputs.push_back(input);
      continue;
    }
    std::vector<StudyTrial> trials = read_study_database(file);
    seen.push_back(file);
    input.trials = trials.size();

    // Each row once: a copy of a row already read is left out, unless it finished and the kept one
    // did not.
    for (StudyTrial& t : trials) {
      if (t.ended_at) ++input.finished;
      Key key{t.station, t.participant, t.study, t.trial, t.seed, t.started_at};
      const auto it = unique.find(key);
      if (it == unique.end()) {
        order.push_back(key);
        unique.emplace(std::move(key), std::move(t));
        continue;
      }
      ++input.duplicates;
      StudyTrial& kept = it->second;
      DuplicateTrial dup;
      dup.differs = !same_content(kept, t);
      if (!kept.ended_at && t.ended_at) {
        dup.kept = row_name(t);
        dup.dropped = row_name(kept);
        kept = std::move(t);
      } else {
        dup.kept = row_name(kept);
        dup.dropped = row_name(t);
      }
      merged.duplicates.push_back(std::move(dup));
    }
    merged.inputs.push_back(input);
  }

  // Finished and unfinished trials, each by participant and start time.
  for (const Key& key : order) {
    StudyTrial& t = unique.at(key);
    (t.ended_at ? merged.finished : merged.unfinished).push_back(std::move(t));
  }
  auto by_time = [](const StudyTrial& a, const StudyTrial& b) {
    return std::tie(a.participant, a.started_at, a.station, a.study, a.trial) <
           std::tie(b.participant, b.started_at, b.station, b.study, b.trial);
  };
  std::stable_sort(merged.finished.begin(), merged.finished.end(), by_time);
  std::stable_sort(merged.unfinished.begin(), merged.unfinished.end(), by_time);
  return merged;
}

}  // namespace cariesim::training
