// Reading study databases (study_schema.hpp) for `cariesim report` and merging the databases of many
// stations: only the columns the schema file names are read, so columns a later writer adds do not
// matter.
#include <fmt/format.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <tuple>

#include "cariesim/common/error.hpp"
#include "cariesim/io/sqlite.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/training/report.hpp"
#include "cariesim/training/run.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace fs = std::filesystem;
using io::Database;
using io::Statement;

namespace {

// Where a bad value is: "FILE: TABLE, row N (CONTEXT), column C".
std::string where(const std::string& file, std::string_view table, std::int64_t row,
                  const std::string& context, std::string_view column) {
  return file + ": " + std::string(table) + ", row " + std::to_string(row) +
         (context.empty() ? std::string() : " (" + context + ")") + ", column " + std::string(column);
}

// Typed reads of one column: the stored type must be the declared one (SQLite keeps any type in
// any column), else the row is refused by name.
std::int64_t integer_column(const Statement& row, int column, const std::string& at) {
  if (row.type(column) != SQLITE_INTEGER)
    throw Error(at + ": stored as " + std::string(io::type_name(row.type(column))) + ", expected an INTEGER");
  return row.integer(column);
}

std::string text_column(const Statement& row, int column, const std::string& at) {
  if (row.type(column) != SQLITE_TEXT)
    throw Error(at + ": stored as " + std::string(io::type_name(row.type(column))) + ", expected TEXT");
  return row.text(column);
}

double real_column(const Statement& row, int column, const std::string& at) {
  if (row.type(column) != SQLITE_FLOAT)
    throw Error(at + ": stored as " + std::string(io::type_name(row.type(column))) +
                ", expected a REAL number");
  return row.real(column);
}

// A score row against its rule (study_schema.hpp): unit, level, range, whole numbers for counts.
void check_score(const TrialScore& s, const ScoreRule& rule, const std::string& file, std::int64_t row,
                 const std::string& context) {
  if (s.unit != rule.unit)
    throw Error(where(file, "scores", row, context, "unit") + ": '" + s.unit + "' is not the unit of " +
                std::string(rule.name) + " ('" + std::string(rule.unit) + "')");
  if (std::find(rule.levels.begin(), rule.levels.end(), s.level) == rule.levels.end()) {
    std::string levels;
    for (const std::string_view l : rule.levels) levels += (levels.empty() ? "" : ", ") + std::string(l);
    throw Error(where(file, "scores", row, context, "level") + ": '" + s.level + "' is not a level of " +
                std::string(rule.name) + " (" + (levels.empty() ? "none" : levels) + ")");
  }
  if (!std::isfinite(s.value) || s.value < rule.lo || s.value > rule.hi ||
      (rule.integral && s.value != std::floor(s.value)))
    throw Error(fmt::format("{}: {} is not a value of {} (expected {} in [{}, {}]{})",
                            where(file, "scores", row, context, "value"), s.value, rule.name,
                            rule.integral ? "a whole number" : "a number", rule.lo, rule.hi,
                            rule.unit.empty() ? "" : " " + std::string(rule.unit)));
}

// Bounds of a recorded case (a station writes a handful of lesions and marks per case).
constexpr std::uintmax_t kMaxAnswersBytes = std::uintmax_t{4} << 20;
constexpr std::size_t kMaxCaseLesions = 1000;
constexpr std::size_t kMaxCaseMarks = 100000;
constexpr double kMaxMarkTime = 1e6;       // s, as a score's time (study_schema.cpp)
constexpr double kMaxTipCoordinate = 1e4;  // mm

// "mild" or "severe", else refused by path.
std::string grade_text(const io::Reader& r, const YAML::Node& node, const std::string& path) {
  std::string g = r.text(node, path);
  if (g != "mild" && g != "severe") r.fail(node, path, "'" + g + "' is not a grade (mild, severe)");
  return g;
}

// A finished diagnosis trial's answers (docs/training.md, "the study database"): the case's lesions
// and the marks, each field of its type and range; keys this cariesim does not read (a later one's)
// are left alone. A trial recorded without them (`{}`) has no recorded case.
std::optional<RecordedCase> parse_case(const std::string& text, const std::string& at) try {
  const YAML::Node root = io::parse_document(text, at, kMaxAnswersBytes);
  const io::Reader r(at);
  if (!root.IsMap()) r.fail(root, "answers", "expected a JSON object");
  const YAML::Node lesions = root["lesions"];
  if (!lesions.IsDefined()) return std::nullopt;
  RecordedCase out;
  r.require_sequence(lesions, "lesions");
  if (lesions.size() > kMaxCaseLesions)
    r.fail(lesions, "lesions", fmt::format("{} lesions, more than {}", lesions.size(), kMaxCaseLesions));
  for (std::size_t i = 0; i < lesions.size(); ++i) {
    const std::string path = io::indexed("lesions", i);
    if (!lesions[i].IsMap()) r.fail(lesions[i], path, "expected an object");
    RecordedLesion l;
    l.site = r.text(lesions[i]["site"], path + ".site");
    l.severity = grade_text(r, lesions[i]["severity"], path + ".severity");
    out.lesions.push_back(std::move(l));
  }
  const YAML::Node marks = root["marks"];
  if (!marks.IsDefined()) r.fail(root, "marks", "missing (the case has lesions)");
  r.require_sequence(marks, "marks");
  if (marks.size() > kMaxCaseMarks)
    r.fail(marks, "marks", fmt::format("{} marks, more than {}", marks.size(), kMaxCaseMarks));
  std::vector<bool> found(out.lesions.size(), false);
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const std::string path = io::indexed("marks", i);
    const YAML::Node& n = marks[i];
    if (!n.IsMap()) r.fail(n, path, "expected an object");
    RecordedMark m;
    m.t = r.number_in(n["t"], path + ".t", 0.0, kMaxMarkTime, "s");
    m.grade = grade_text(r, n["grade"], path + ".grade");
    m.contact = r.boolean(n["contact"], path + ".contact");
    const Vec3 tip = r.vec3(n["tip"], path + ".tip");
    for (int k = 0; k < 3; ++k) {
      if (std::abs(tip[k]) > kMaxTipCoordinate)
        r.fail(n["tip"], path + ".tip", fmt::format("{} mm is out of range", tip[k]));
      m.tip[k] = tip[k];
    }
    if (const YAML::Node lesion = n["lesion"]; lesion.IsDefined() && !lesion.IsNull()) {
      m.lesion = static_cast<int>(
          r.integer_in(lesion, path + ".lesion", 1, static_cast<std::int64_t>(out.lesions.size())));
      // Only a lesion's first mark finds it (docs/training.md, "Scores").
      m.first = r.boolean(n["first"], path + ".first");
      if (m.first && found[static_cast<std::size_t>(m.lesion - 1)])
        r.fail(n["first"], path + ".first", fmt::format("lesion {} has an earlier first mark", m.lesion));
      if (m.first) found[static_cast<std::size_t>(m.lesion - 1)] = true;
    }
    out.marks.push_back(std::move(m));
  }
  return out;
} catch (const YAML::Exception& e) {
  throw Error(fmt::format("{}: not the answers a station writes: {}", at, e.what()));
}

// Trial results waiting beside a database (run.cpp writes them while it is locked), counted up to a
// bound; they are read only by the run that merges them.
std::size_t count_pending(const fs::path& database) {
  constexpr std::size_t kMaxCounted = 100000;
  std::error_code ec;
  const fs::path dir = pending_folder(database);
  if (!fs::is_directory(dir, ec)) return 0;
  std::size_t count = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.starts_with("trial-") && name.ends_with(".json") && ++count >= kMaxCounted) break;
  }
  return count;
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
  // Read-only through the defensive opener: exactly the study schema, none of the file's own SQL,
  // bounded work, nothing made beside the file (io/sqlite.hpp).
  const std::unique_ptr<Database> db = io::open_input(file, study_schema(false));
  const std::string name = file.string();
  std::vector<StudyTrial> trials;
  // One read transaction, so a station still writing cannot change the file between the queries.
  db->exec("BEGIN", "cannot begin reading");

  // The trial rows, each column of its declared type.
  std::map<std::int64_t, std::size_t> by_id;
  {
    Statement rows(
        *db,
        "SELECT id, station, participant, study, kind, trial, seed, started_at, ended_at, answers FROM trials"
        " ORDER BY id");
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      StudyTrial t;
      t.file = name;
      t.id = rows.integer(0);
      const auto at = [&](std::string_view column) { return where(name, "trials", t.id, "", column); };
      t.station = text_column(rows, 1, at("station"));
      t.participant = text_column(rows, 2, at("participant"));
      t.study = text_column(rows, 3, at("study"));
      t.kind = text_column(rows, 4, at("kind"));
      t.trial = integer_column(rows, 5, at("trial"));
      if (t.trial < 1)
        throw Error(at("trial") + ": " + std::to_string(t.trial) + " is not a trial number (from 1)");
      t.seed = integer_column(rows, 6, at("seed"));
      t.started_at = text_column(rows, 7, at("started_at"));
      if (!rows.is_null(8)) t.ended_at = text_column(rows, 8, at("ended_at"));
      // A trainee's trial that never ended keeps kSeedNotWritten (run.hpp); any other seed is >= 0.
      if (t.seed < 0 && !(t.seed == kSeedNotWritten && !t.ended_at))
        throw Error(at("seed") + ": " + std::to_string(t.seed) + " is not a trial seed (>= 0)");
      // A finished diagnosis case's lesions and marks, for the gradebook.
      if (t.ended_at && t.kind == kKindDiagnosis)
        t.diagnosis_case = parse_case(text_column(rows, 9, at("answers")), at("answers"));
      by_id[t.id] = trials.size();
      trials.push_back(std::move(t));
    }
    if (rc != SQLITE_DONE) db->fail("cannot read the trials");
  }

  // Their scores: each known score checked against its rule; a score this cariesim does not know
  // (a later one's) is not used by any table and is left out.
  {
    Statement rows(*db, "SELECT rowid, trial_id, name, level, value, unit FROM scores ORDER BY rowid");
    int rc = SQLITE_ROW;
    while ((rc = rows.step()) == SQLITE_ROW) {
      const std::int64_t row = rows.integer(0);
      const std::int64_t trial_id = integer_column(rows, 1, where(name, "scores", row, "", "trial_id"));
      const auto it = by_id.find(trial_id);
      if (it == by_id.end())
        throw Error(name + ": scores: a score of trial id " + std::to_string(trial_id) +
                    " that the trials table lacks (row " + std::to_string(row) + ")");
      TrialScore s;
      s.name =
          text_column(rows, 2, where(name, "scores", row, "trial id " + std::to_string(trial_id), "name"));
      const std::string context = "trial id " + std::to_string(trial_id) + ", score '" + s.name + "'";
      s.level = text_column(rows, 3, where(name, "scores", row, context, "level"));
      s.value = real_column(rows, 4, where(name, "scores", row, context, "value"));
      s.unit = text_column(rows, 5, where(name, "scores", row, context, "unit"));
      const ScoreRule* rule = find_score_rule(s.name);
      if (rule == nullptr) continue;
      check_score(s, *rule, name, row, context);
      trials[it->second].scores.push_back(std::move(s));
    }
    if (rc != SQLITE_DONE) db->fail("cannot read the scores");
  }
  db->exec("COMMIT", "cannot end reading");
  db->check_input_unchanged();
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
    input.pending = count_pending(file);

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
