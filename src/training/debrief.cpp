// Rebuilding a trial from its study database and the debrief of a diagnosis case (docs/training.md,
// "Debrief" and "Rebuilding a trial"). The database is hostile input: the defensive opener, typed
// columns, the stored study text against its hash, the stored case against the rebuilt one.

#include "cariesim/training/debrief.hpp"

#include <fmt/format.h>
#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <memory>

#include "cariesim/common/error.hpp"
#include "cariesim/common/hash.hpp"
#include "cariesim/io/sqlite.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace fs = std::filesystem;
using io::Database;
using io::Statement;

namespace {

// Bounds of what one trial's answers may hold.
constexpr std::size_t kMaxMarks = 100000;
constexpr std::size_t kMaxLesions = 1000;
constexpr std::size_t kMaxOverrides = 1000;
constexpr double kMaxCoordinate = 1.0e6;  // mm
constexpr double kMaxTime = 1.0e6;        // s

// "FILE: TABLE, row N, column C".
std::string cell(const fs::path& file, std::string_view table, int64_t row, std::string_view column) {
  return fmt::format("{}: {}, row {}, column {}", file.string(), table, row, column);
}

// Typed reads: the stored type must be the declared one, else the cell is named.
int64_t integer_at(const Statement& s, int column, const std::string& at) {
  if (s.type(column) != SQLITE_INTEGER)
    throw Error(fmt::format("{}: stored as {}, expected an INTEGER", at, io::type_name(s.type(column))));
  return s.integer(column);
}
std::string text_at(const Statement& s, int column, const std::string& at) {
  if (s.type(column) != SQLITE_TEXT)
    throw Error(fmt::format("{}: stored as {}, expected TEXT", at, io::type_name(s.type(column))));
  return s.text(column);
}

// 16 hex digits -> the hash; unset for anything else.
std::optional<uint64_t> parse_hex16(const std::string& text) {
  if (text.size() != 16 || text.find_first_not_of("0123456789abcdef") != std::string::npos)
    return std::nullopt;
  uint64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, 16);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// A number stored in trials.answers (the JSON writer keeps 6 significant digits, io/json.hpp) and
// the one it was written from.
bool same_number(double a, double b) { return std::abs(a - b) <= 1e-5 * std::max(1e-3, std::abs(b)); }

// "lesion 1 at 46-occlusal (severe, 2.2 mm, 2 mm deep)".
std::string case_text(const std::vector<CaseLesion>& lesions) {
  std::string out;
  for (std::size_t i = 0; i < lesions.size(); ++i)
    out += fmt::format("{}lesion {} at {} ({}, {:.3g} mm, {:.3g} mm deep)", i == 0 ? "" : ", ", i + 1,
                       lesions[i].site, grade_name(lesions[i].severity), lesions[i].size, lesions[i].depth);
  return out.empty() ? "no lesion" : out;
}

// "m:ss".
std::string clock(double seconds) {
  const int s = static_cast<int>(std::lround(std::max(seconds, 0.0)));
  return fmt::format("{}:{:02d}", s / 60, s % 60);
}

// The first score of `name` (any level), if any.
std::optional<double> score_of(const std::vector<Score>& scores, std::string_view name) {
  for (const Score& s : scores)
    if (s.name == name) return s.value;
  return std::nullopt;
}

// "1 mark" / "2 marks".
std::string count(std::size_t n, std::string_view one, std::string_view many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

}  // namespace

DiagnosisAnswers parse_diagnosis_answers(std::string_view json, const std::string& where) {
  // JSON is YAML: the bounded strict reader, every field checked.
  const YAML::Node root = io::parse_document(json, where);
  const io::Reader r(where);
  const io::Fields f(r, root, "", {"lesions", "marks", "ended_at", "error"});
  if (f.has("error")) r.fail(f.get("error"), "error", "the trial did not end (it holds an error)");
  DiagnosisAnswers out;
  const YAML::Node lesions = f.require("lesions");
  r.require_sequence(lesions, "lesions");
  if (lesions.size() > kMaxLesions)
    r.fail(lesions, "lesions", fmt::format("more than {} lesions", kMaxLesions));
  for (std::size_t i = 0; i < lesions.size(); ++i) {
    const io::Fields l(r, lesions[i], io::indexed("lesions", i),
                       {"site", "severity", "size", "width", "depth", "shape", "offset"});
    CaseLesion c;
    c.site = r.text(l.require("site"), l.sub("site"));
    if (!parse_grade(r.text(l.require("severity"), l.sub("severity")), c.severity))
      r.fail(l.require("severity"), l.sub("severity"), "expected mild or severe");
    c.size = r.number_in(l.require("size"), l.sub("size"), 0.0, 1000.0, "mm");
    c.width = r.number_in(l.require("width"), l.sub("width"), 0.0, 1000.0, "mm");
    c.depth = r.number_in(l.require("depth"), l.sub("depth"), 0.0, 1000.0, "mm");
    // The drawn shape and place in the site's region (written since sites became regions; older rows
    // have neither, and then the defaults stand).
    if (const YAML::Node n = l.get("shape"); n.IsDefined()) {
      out.placed = true;
      if (!parse_lesion_kind(r.text(n, l.sub("shape")), c.shape))
        r.fail(n, l.sub("shape"), "expected disk, inverted-cone, stripe or ellipsoid");
    }
    if (const YAML::Node n = l.get("offset"); n.IsDefined()) {
      out.placed = true;
      r.require_sequence(n, l.sub("offset"));
      if (n.size() != 2) r.fail(n, l.sub("offset"), "expected [along, across] (mm)");
      for (std::size_t k = 0; k < 2; ++k)
        c.offset[k] = r.number_in(n[k], io::indexed(l.sub("offset"), k), -1000.0, 1000.0, "mm");
    }
    out.lesions.push_back(c);
  }
  const YAML::Node marks = f.require("marks");
  r.require_sequence(marks, "marks");
  if (marks.size() > kMaxMarks) r.fail(marks, "marks", fmt::format("more than {} marks", kMaxMarks));
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const io::Fields m(r, marks[i], io::indexed("marks", i),
                       {"t", "grade", "contact", "tip", "lesion", "distance", "first"});
    JudgedMark j;
    j.mark.t = r.number_in(m.require("t"), m.sub("t"), -kMaxTime, kMaxTime, "s");
    if (!parse_grade(r.text(m.require("grade"), m.sub("grade")), j.mark.grade))
      r.fail(m.require("grade"), m.sub("grade"), "expected mild or severe");
    j.mark.contact = r.boolean(m.require("contact"), m.sub("contact"));
    j.mark.tip = r.vec3(m.require("tip"), m.sub("tip"));
    if (j.mark.tip.cwiseAbs().maxCoeff() > kMaxCoordinate)
      r.fail(m.require("tip"), m.sub("tip"), "a coordinate beyond 1e6 mm");
    if (const YAML::Node n = m.get("lesion"); n.IsDefined() && !n.IsNull())
      j.lesion =
          static_cast<int>(r.integer_in(n, m.sub("lesion"), 1, static_cast<int64_t>(out.lesions.size()))) - 1;
    if (const YAML::Node n = m.get("distance"); n.IsDefined())
      j.distance = r.number_in(n, m.sub("distance"), 0.0, kMaxCoordinate, "mm");
    if (const YAML::Node n = m.get("first"); n.IsDefined()) j.first = r.boolean(n, m.sub("first"));
    if (j.first && j.lesion < 0) r.fail(marks[i], io::indexed("marks", i), "a first mark on no lesion");
    out.marks.push_back(j);
  }
  if (const YAML::Node n = f.get("ended_at"); n.IsDefined() && !n.IsNull())
    out.ended_at = r.number_in(n, "ended_at", -kMaxTime, kMaxTime, "s");
  return out;
}

std::string RebuiltTrial::label() const {
  return fmt::format("{}, trial {} (row {})", participant, number, row);
}

RebuiltTrial rebuild_trial(const fs::path& database, const std::string& participant,
                           std::optional<int> number) {
  // Read-only through the defensive opener, in one read transaction.
  const std::unique_ptr<Database> db = io::open_input(database, study_schema(false));
  db->exec("BEGIN", "cannot begin reading");
  const int version = study_schema_version(*db);
  RebuiltTrial t;
  t.database = database;

  // The participant: given, or the only one in the file.
  t.participant = participant;
  if (t.participant.empty()) {
    Statement who(*db, "SELECT DISTINCT participant FROM trials ORDER BY participant LIMIT 21");
    std::vector<std::string> names;
    int rc = SQLITE_ROW;
    while ((rc = who.step()) == SQLITE_ROW) names.push_back(who.type(0) == SQLITE_TEXT ? who.text(0) : "?");
    if (rc != SQLITE_DONE) db->fail("cannot read the trials");
    if (names.empty()) throw Error(database.string() + ": no trial in this study database");
    if (names.size() > 1) {
      std::string list;
      for (std::size_t i = 0; i < std::min<std::size_t>(names.size(), 20); ++i)
        list += (i == 0 ? "" : ", ") + names[i];
      throw Error(
          fmt::format("{}: it holds the trials of several participants ({}{}); name one with --participant",
                      database.string(), list, names.size() > 20 ? ", ..." : ""));
    }
    t.participant = names.front();
  }

  // Unnumbered: the participant's last ended trial.
  if (!number) {
    Statement ends(*db, "SELECT ended_at IS NOT NULL FROM trials WHERE participant = ? ORDER BY id");
    ends.bind(0, t.participant);
    int rc = SQLITE_ROW;
    int n = 0;
    while ((rc = ends.step()) == SQLITE_ROW)
      if (++n, ends.integer(0) != 0) number = n;
    if (rc != SQLITE_DONE) db->fail("cannot read the trials");
    if (n > 0 && !number)
      throw Error(
          fmt::format("{}: no trial of participant '{}' has ended", database.string(), t.participant));
  }
  // The participant's trials in row order; the N-th.
  std::string answers_text;
  bool diagnosis = false;
  {
    Statement rows(*db,
                   "SELECT id, station, study, kind, trial, seed, started_at, ended_at, recording, answers"
                   " FROM trials WHERE participant = ? ORDER BY id");
    rows.bind(0, t.participant);
    int rc = SQLITE_ROW;
    int n = 0;
    bool chosen = false;
    while ((rc = rows.step()) == SQLITE_ROW) {
      ++n;
      const bool ended = !rows.is_null(7);
      if (number ? n != *number : !ended) continue;
      chosen = true;
      t.number = n;
      t.row = integer_at(rows, 0, cell(database, "trials", 0, "id"));
      const auto at = [&](std::string_view column) { return cell(database, "trials", t.row, column); };
      t.station = text_at(rows, 1, at("station"));
      t.study_name = text_at(rows, 2, at("study"));
      const std::string kind = text_at(rows, 3, at("kind"));
      const int64_t run_trial = integer_at(rows, 4, at("trial"));
      if (run_trial < 1 || run_trial > 1000)
        throw Error(fmt::format("{}: {} is not a trial number (1 to 1000)", at("trial"), run_trial));
      t.run_trial = static_cast<int>(run_trial);
      const int64_t seed = integer_at(rows, 5, at("seed"));
      t.started_at = text_at(rows, 6, at("started_at"));
      if (!ended)
        throw Error(fmt::format("{}: {} did not end (no end time): there is nothing to rebuild",
                                at("ended_at"), t.label()));
      t.ended_at = text_at(rows, 7, at("ended_at"));
      if (seed < 0 || static_cast<uint64_t>(seed) > kMaxSeed)
        throw Error(fmt::format("{}: {} is not a trial seed (0 to 2^63 - 1)", at("seed"), seed));
      t.seed = static_cast<uint64_t>(seed);
      if (!rows.is_null(8)) {
        const fs::path stored = text_at(rows, 8, at("recording"));
        t.recording = stored.is_absolute()
                          ? stored
                          : (fs::absolute(database).parent_path() / stored).lexically_normal();
      }
      answers_text = text_at(rows, 9, at("answers"));
      diagnosis = kind == kKindDiagnosis;
      if (kind != kKindTuning && kind != kKindBoundary && kind != kKindDiagnosis)
        throw Error(fmt::format("{}: '{}' is not a study kind", at("kind"), kind));
      break;
    }
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) db->fail("cannot read the trials");
    if (!chosen) {
      if (n == 0)
        throw Error(fmt::format("{}: no trial of participant '{}'", database.string(), t.participant));
      throw Error(number ? fmt::format("{}: participant '{}' has {} trials, not {}", database.string(),
                                       t.participant, n, *number)
                         : fmt::format("{}: no trial of participant '{}' has ended", database.string(),
                                       t.participant));
    }
  }
  const auto at = [&](std::string_view table, int64_t row, std::string_view column) {
    return cell(database, table, row, column);
  };

  // Its source: the study's text (checked against its hash) and the overrides.
  if (version < 2)
    throw Error(
        fmt::format("{}: {} was recorded in a study database of schema version {}, which does not hold "
                    "the study's text: it cannot be rebuilt from the database",
                    database.string(), t.label(), version));
  int64_t study_id = 0;
  std::vector<SceneOverride> overrides;
  {
    Statement source(*db, "SELECT study_id, overrides, scene_hash FROM trial_sources WHERE trial_id = ?");
    source.bind(0, t.row);
    const int rc = source.step();
    if (rc == SQLITE_DONE)
      throw Error(
          fmt::format("{}: {} has no row in trial_sources (it began before the study's text was "
                      "stored): it cannot be rebuilt from the database",
                      database.string(), t.label()));
    if (rc != SQLITE_ROW) db->fail("cannot read the trial sources");
    study_id = integer_at(source, 0, at("trial_sources", t.row, "study_id"));
    const std::string list = text_at(source, 1, at("trial_sources", t.row, "overrides"));
    const std::string where = at("trial_sources", t.row, "overrides");
    const YAML::Node node = io::parse_document(list, where);
    const io::Reader r(where);
    r.require_sequence(node, "overrides");
    if (node.size() > kMaxOverrides) r.fail(node, "overrides", "too many overrides");
    for (std::size_t i = 0; i < node.size(); ++i) {
      const io::Fields o(r, node[i], io::indexed("overrides", i), {"key", "value"});
      overrides.push_back(
          {r.text(o.require("key"), o.sub("key")), r.text(o.require("value"), o.sub("value"))});
    }
    if (!source.is_null(2)) {
      const std::string hex = text_at(source, 2, at("trial_sources", t.row, "scene_hash"));
      t.scene_hash = parse_hex16(hex);
      if (!t.scene_hash)
        throw Error(fmt::format("{}: '{}' is not a scene hash (16 hex digits)",
                                at("trial_sources", t.row, "scene_hash"), hex));
    }
  }
  // The answers (after the source: a trial from before the sources were stored is said to be one).
  if (diagnosis) t.answers = parse_diagnosis_answers(answers_text, at("trials", t.row, "answers"));
  std::string yaml, origin;
  {
    Statement study(*db, "SELECT name, origin, hash, yaml FROM studies WHERE id = ?");
    study.bind(0, study_id);
    const int rc = study.step();
    if (rc == SQLITE_DONE)
      throw Error(fmt::format("{}: study row {} does not exist in studies",
                              at("trial_sources", t.row, "study_id"), study_id));
    if (rc != SQLITE_ROW) db->fail("cannot read the studies");
    const std::string name = text_at(study, 0, at("studies", study_id, "name"));
    origin = text_at(study, 1, at("studies", study_id, "origin"));
    const std::string hash = text_at(study, 2, at("studies", study_id, "hash"));
    yaml = text_at(study, 3, at("studies", study_id, "yaml"));
    const std::string actual = fmt::format("{:016x}", BuildKey().add(yaml).value());
    if (actual != hash)
      throw Error(
          fmt::format("{}: the study's text hashes to {}, not to the stored {} (the text was changed)",
                      at("studies", study_id, "yaml"), actual, hash));
    if (name != t.study_name)
      throw Error(fmt::format("{}: study '{}' is not the trial's study '{}' (trials row {})",
                              at("studies", study_id, "name"), name, t.study_name, t.row));
  }

  // The scores of the trial (finite values of the names this cariesim writes).
  {
    Statement scores(*db,
                     "SELECT rowid, name, level, value, unit FROM scores WHERE trial_id = ? ORDER BY rowid");
    scores.bind(0, t.row);
    int rc = SQLITE_ROW;
    while ((rc = scores.step()) == SQLITE_ROW) {
      const int64_t row = scores.integer(0);
      Score s;
      s.name = text_at(scores, 1, at("scores", row, "name"));
      s.level = text_at(scores, 2, at("scores", row, "level"));
      if (scores.type(3) != SQLITE_FLOAT && scores.type(3) != SQLITE_INTEGER)
        throw Error(fmt::format("{}: stored as {}, expected a REAL number", at("scores", row, "value"),
                                io::type_name(scores.type(3))));
      s.value = scores.real(3);
      s.unit = text_at(scores, 4, at("scores", row, "unit"));
      const ScoreRule* rule = find_score_rule(s.name);
      if (rule == nullptr) continue;
      if (!std::isfinite(s.value) || s.value < rule->lo || s.value > rule->hi || s.unit != rule->unit)
        throw Error(fmt::format("{}: {} {} is not a value of {}", at("scores", row, "value"), s.value, s.unit,
                                s.name));
      t.scores.push_back(std::move(s));
    }
    if (rc != SQLITE_DONE) db->fail("cannot read the scores");
  }
  db->exec("COMMIT", "cannot end reading");
  db->check_input_unchanged();

  // The study from its text, the trial from its seed (make_trial: the draws of docs/training.md).
  try {
    t.study = parse_study(yaml, origin);
  } catch (const Error& e) {
    throw Error(
        fmt::format("{}: the stored study does not read: {}", at("studies", study_id, "yaml"), e.what()));
  }
  try {
    t.setup = make_trial(t.study, t.run_trial - 1, t.seed);
    if (!overrides.empty())
      t.setup.scene_yaml = override_scene_text(t.setup.scene_yaml, t.setup.scene_origin, overrides);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {} cannot be remade: {}", database.string(), t.label(), e.what()));
  }

  // The case the trial ran (its stored answers) must be the case its seed rebuilds.
  if (t.study.kind == StudyKind::Diagnosis) {
    const auto& stored = t.answers.lesions;
    const auto& rebuilt = t.setup.truth.lesions;
    bool same = stored.size() == rebuilt.size();
    for (std::size_t i = 0; same && i < stored.size(); ++i)
      same = stored[i].site == rebuilt[i].site && stored[i].severity == rebuilt[i].severity &&
             same_number(stored[i].size, rebuilt[i].size) && same_number(stored[i].width, rebuilt[i].width) &&
             same_number(stored[i].depth, rebuilt[i].depth) &&
             (!t.answers.placed || (stored[i].shape == rebuilt[i].shape &&
                                    same_number(stored[i].offset[0], rebuilt[i].offset[0]) &&
                                    same_number(stored[i].offset[1], rebuilt[i].offset[1])));
    if (!same)
      throw Error(
          fmt::format("{}: the stored case ({}) is not the case seed {} rebuilds ({}): the row was "
                      "changed, or the study draws its cases differently now",
                      at("trials", t.row, "answers"), case_text(stored), t.seed, case_text(rebuilt)));
  }
  return t;
}

void check_rebuilt_scene(const RebuiltTrial& trial, const Model& model, const SessionInfo* recording) {
  // The stored hash, then the recording's own: each must be the rebuilt model's.
  if (trial.scene_hash && *trial.scene_hash != model.scene_hash)
    throw Error(
        fmt::format("{}: the scene rebuilt for {} has the hash {:016x}, the recorded scene {:016x}: the "
                    "database, the study's "
                    "scene or this cariesim's scene building changed since the trial ran",
                    cell(trial.database, "trial_sources", trial.row, "scene_hash"), trial.label(),
                    model.scene_hash, *trial.scene_hash));
  if (recording != nullptr && recording->scene_hash != model.scene_hash)
    throw Error(
        fmt::format("{}: session.scene_hash {:016x} is not the hash {:016x} of the scene rebuilt for {} "
                    "from {}: the recording is of another scene",
                    trial.recording.string(), recording->scene_hash, model.scene_hash, trial.label(),
                    trial.database.string()));
}

std::string_view mark_verdict_name(MarkVerdict verdict) {
  switch (verdict) {
    case MarkVerdict::Found:
      return "found";
    case MarkVerdict::Again:
      return "again";
    case MarkVerdict::False:
      return "false";
    case MarkVerdict::InAir:
      return "in the air";
  }
  return "false";
}

Debrief make_debrief(const TrialSetup& setup, const DiagnosisAnswers& answers,
                     const std::vector<Score>& scores, const Recording* recording,
                     const ScoringDesc& scoring) {
  if (setup.kind != StudyKind::Diagnosis) throw Error("debrief: only a diagnosis case has a debrief");
  Debrief d;
  d.time_limit = setup.time_limit;
  const std::size_t n = setup.truth.lesions.size();

  // The lesions revealed, and each mark judged as stored.
  for (std::size_t i = 0; i < n; ++i) {
    const CaseLesion& c = setup.truth.lesions[i];
    d.lesions.push_back({static_cast<int>(i) + 1, c.site, c.severity, c.size, c.depth, false, {}, {}});
  }
  for (std::size_t i = 0; i < answers.marks.size(); ++i) {
    const JudgedMark& j = answers.marks[i];
    if (j.lesion >= static_cast<int>(n))
      throw Error(fmt::format("debrief: mark {} names lesion {}; the case has {}", i + 1, j.lesion + 1, n));
    DebriefMark m;
    m.number = static_cast<int>(i) + 1;
    m.t = j.mark.t;
    m.grade = j.mark.grade;
    m.tip = j.mark.tip;
    m.distance = j.distance;
    m.lesion = j.lesion >= 0 ? j.lesion + 1 : -1;
    m.verdict = !j.mark.contact ? MarkVerdict::InAir
                : j.lesion < 0  ? MarkVerdict::False
                : j.first       ? MarkVerdict::Found
                                : MarkVerdict::Again;
    if (m.verdict == MarkVerdict::Found) {
      DebriefLesion& l = d.lesions[static_cast<std::size_t>(j.lesion)];
      l.found = true;
      l.graded = m.grade;
      l.found_at = m.t;
    }
    d.marks.push_back(m);
  }

  // The insertions: the recording's penetration episodes into a lesion of the case.
  if (recording != nullptr)
    for (const RecordedEvent& e : recording->events)
      if (e.kind == "penetration" && e.lesion >= 0 && e.lesion < static_cast<int>(n))
        d.insertions.push_back({e.t, e.lesion + 1, e.value, e.duration});

  // The scores in words.
  const auto found = static_cast<std::size_t>(
      std::count_if(d.lesions.begin(), d.lesions.end(), [](const DebriefLesion& l) { return l.found; }));
  if (n == 0)
    d.lines.push_back("This case had no lesion.");
  else
    d.lines.push_back(
        fmt::format("You found {} of {} lesions{}.", found, n, found == n ? ": all of them" : ""));
  for (const DebriefLesion& l : d.lesions) {
    if (l.found)
      d.lines.push_back(
          fmt::format("Lesion {} ({}, {}): found at {}, graded {}: {}.", l.number, l.site,
                      grade_name(l.severity), clock(*l.found_at), grade_name(*l.graded),
                      l.grade_right() ? "right" : fmt::format("wrong, it is {}", grade_name(l.severity))));
    else
      d.lines.push_back(fmt::format("Lesion {} ({}, {}): missed, no mark on it.", l.number, l.site,
                                    grade_name(l.severity)));
  }
  std::size_t false_marks = 0, in_air = 0, again = 0;
  for (const DebriefMark& m : d.marks) {
    false_marks += m.verdict == MarkVerdict::False ? 1 : 0;
    in_air += m.verdict == MarkVerdict::InAir ? 1 : 0;
    again += m.verdict == MarkVerdict::Again ? 1 : 0;
  }
  if (false_marks + in_air == 0)
    d.lines.push_back("No false marks: every mark was on a lesion.");
  else
    d.lines.push_back(fmt::format(
        "{} where there is no lesion{}.", count(false_marks + in_air, "false mark", "false marks"),
        in_air > 0 ? fmt::format(" ({} made with the tool touching nothing)", in_air) : ""));
  if (again > 0)
    d.lines.push_back(fmt::format("{} on a lesion already found (only the first mark counts).",
                                  count(again, "mark was", "marks were")));
  if (found > 0) {
    const auto right = static_cast<std::size_t>(std::count_if(
        d.lesions.begin(), d.lesions.end(), [](const DebriefLesion& l) { return l.grade_right(); }));
    d.lines.push_back(
        fmt::format("Grades: {} of the {} found graded right.", right, count(found, "lesion", "lesions")));
  }
  d.case_time = score_of(scores, kScoreCaseTime).value_or(answers.ended_at.value_or(0.0));
  d.lines.push_back(answers.ended_at
                        ? fmt::format("You ended the case after {}.", clock(d.case_time))
                        : fmt::format("The case ended after {} (the time limit or the end of the motion).",
                                      clock(d.case_time)));
  if (const auto soft = score_of(scores, kScoreSoftTissueTime)) {
    const double threshold = scoring.soft_tissue_threshold.value_or(
        recording != nullptr && recording->soft_tissue_threshold > 0.0 ? recording->soft_tissue_threshold
                                                                       : 1.0);
    if (*soft > 0.0)
      d.lines.push_back(
          fmt::format("You pressed the gum or tongue harder than {:g} N for {:.1f} s (strongest {:.1f} N): "
                      "that hurts a patient.",
                      threshold, *soft, score_of(scores, kScoreSoftTissuePeak).value_or(0.0)));
    else
      d.lines.push_back("You never pressed the gum or tongue too hard.");
  }
  if (const auto hard = score_of(scores, kScoreEnamelExcessTime)) {
    if (*hard > 0.0)
      d.lines.push_back(
          fmt::format("You pushed on healthy tooth harder than {:g} N for {:.1f} s (strongest {:.1f} N): "
                      "too hard for probing.",
                      scoring.enamel_force_limit, *hard, score_of(scores, kScoreEnamelPeak).value_or(0.0)));
    else
      d.lines.push_back("You never pushed too hard on healthy tooth.");
  }
  if (const auto blocked = score_of(scores, kScoreBlockedInsertions); blocked && *blocked > 0.0)
    d.lines.push_back(
        fmt::format("{} the explorer pressed on caries without going in: tilt it so the tip, not "
                    "the shank, leads.",
                    count(static_cast<std::size_t>(*blocked), "time", "times")));
  if (recording != nullptr)
    d.lines.push_back(
        d.insertions.empty()
            ? std::string("The explorer never went into a lesion.")
            : fmt::format("The explorer went into a lesion {} (listed below with their moments).",
                          count(d.insertions.size(), "time", "times")));
  return d;
}

}  // namespace cariesim::training
