// The tables of `cariesim report` (docs/reports.md) from merged study databases. Each participant's
// values are the mean ± sample SD over their finished trials; the cohort row is the mean ± SD of the
// participant means, as the paper's "Average" rows of Tables 1-2 and its boundary score 7.2 ± 1.69.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <string>
#include <tuple>

#include "cariesim/training/report.hpp"
#include "training/stats.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace {

constexpr const char* kCohort = "cohort";
constexpr const char* kMild = "mild";
constexpr const char* kSevere = "severe";

Cell text(const std::string& s) { return Cell::of_text(s); }
Cell integer(std::size_t n) { return Cell::of_integer(static_cast<std::int64_t>(n)); }
Cell id(std::int64_t n) { return Cell::of_integer(n); }
Cell real(double v) { return Cell::of_number(v); }
Cell number(const std::optional<double>& v) { return v ? Cell::of_number(*v) : Cell{}; }

// The finished trials of one participant, in time order (merge_study_databases sorts them so).
using Participants = std::map<std::string, std::vector<const StudyTrial*>>;

Participants by_participant(const std::vector<StudyTrial>& trials) {
  Participants out;
  for (const StudyTrial& t : trials) out[t.participant].push_back(&t);
  return out;
}

// Every value of score `name` (and `level`, unless null) in `trials`.
std::vector<double> values_of(const std::vector<const StudyTrial*>& trials, std::string_view name,
                              const char* level) {
  std::vector<double> out;
  for (const StudyTrial* t : trials)
    for (const TrialScore& s : t->scores)
      if (s.name == name && (level == nullptr || s.level == level)) out.push_back(s.value);
  return out;
}

// The trials that hold at least one of `names`.
std::vector<const StudyTrial*> trials_with(const std::vector<const StudyTrial*>& trials,
                                           const std::vector<std::string_view>& names) {
  std::vector<const StudyTrial*> out;
  for (const StudyTrial* t : trials) {
    const bool has = std::any_of(t->scores.begin(), t->scores.end(), [&](const TrialScore& s) {
      return std::find(names.begin(), names.end(), s.name) != names.end();
    });
    if (has) out.push_back(t);
  }
  return out;
}

// Sum of the values of score `name` over one trial (e.g. the shapes named right in it).
std::optional<double> trial_sum(const StudyTrial& t, std::string_view name) {
  std::optional<double> sum;
  for (const TrialScore& s : t.scores)
    if (s.name == name) sum = sum.value_or(0.0) + s.value;
  return sum;
}

// Adds a KEY_mean / KEY_sd pair of columns.
void add_mean_sd(ReportTable& table, const std::string& key, const std::string& header, int decimals) {
  table.columns.push_back({key + "_mean", header, decimals});
  table.columns.push_back({key + "_sd", header + " SD", decimals});
}

void put_summary(std::vector<Cell>& row, const Summary& s) {
  row.push_back(number(s.mean));
  row.push_back(number(s.sd));
}

// Collects, per column of mean/SD pairs, the participant means for the cohort row.
struct CohortColumns {
  std::vector<std::vector<double>> means;
  explicit CohortColumns(std::size_t columns) : means(columns) {}
  void add(std::size_t column, const Summary& s) {
    if (s.mean) means[column].push_back(*s.mean);
  }
  Summary summary(std::size_t column) const { return summarize(means[column]); }
};

// Tables 1 and 2: per participant and level, mean ± SD of the tuned values of two parameters.
ReportTable tuning_table(const Participants& people, const std::string& name, const std::string& title,
                         const std::string& caption, std::string_view p1, const std::string& h1,
                         std::string_view p2, const std::string& h2, int decimals) {
  ReportTable table{name, title, caption, {}, {}};
  table.columns.push_back({"participant", "Participant", 0});
  table.columns.push_back({"trials", "Trials", 0});
  const struct {
    const char* level;
    std::string_view score;
    std::string header;
  } cells[] = {{kMild, p1, "Mild " + h1},
               {kMild, p2, "Mild " + h2},
               {kSevere, p1, "Severe " + h1},
               {kSevere, p2, "Severe " + h2}};
  for (const auto& c : cells)
    add_mean_sd(table, std::string(c.level) + "_" + std::string(c.score), c.header, decimals);

  CohortColumns cohort(4);
  std::size_t total = 0, participants = 0;
  for (const auto& [who, trials] : people) {
    const std::vector<const StudyTrial*> tuned = trials_with(trials, {p1, p2});
    if (tuned.empty()) continue;
    ++participants;
    total += tuned.size();
    std::vector<Cell> row{text(who), integer(tuned.size())};
    for (std::size_t i = 0; i < 4; ++i) {
      const Summary s = summarize(values_of(tuned, cells[i].score, cells[i].level));
      cohort.add(i, s);
      put_summary(row, s);
    }
    table.rows.push_back(std::move(row));
  }
  if (participants > 0) {
    std::vector<Cell> row{text(kCohort), integer(total)};
    for (std::size_t i = 0; i < 4; ++i) put_summary(row, cohort.summary(i));
    table.rows.push_back(std::move(row));
  }
  return table;
}

// "F(1, 8) = 14.496, p = 0.00518", as the paper writes it, or the reason there is no F.
std::string result_text(const Anova& a) {
  if (!a.f || !a.p) return "F undefined";
  return fmt::format("F({}, {}) = {:.3f}, p = {:.3g}", a.df1, a.df2, *a.f, *a.p);
}

// The one-way ANOVA between mild and severe per parameter, one observation per participant (their
// mean), as the paper's F(1, 8) for five dentists (§4.1.2, §5.2).
ReportTable anova_table(const Participants& people) {
  ReportTable table{"anova",
                    "One-way ANOVA between levels",
                    "Per parameter, mild against severe; the observations are the participants' mean tuned "
                    "values (one per participant and level, as the paper's F(1, 8) for five dentists). "
                    "F = (SS_between / df1) / (SS_within / df2); p = P(F(df1, df2) > F).",
                    {},
                    {}};
  table.columns = {{"parameter", "Parameter", 0},
                   {"unit", "Unit", 0},
                   {"mild_mean", "Mild mean", 3},
                   {"severe_mean", "Severe mean", 3},
                   {"n_mild", "n mild", 0},
                   {"n_severe", "n severe", 0},
                   {"ss_between", "SS between", 4},
                   {"ss_within", "SS within", 4},
                   {"df1", "df1", 0},
                   {"df2", "df2", 0},
                   {"F", "F", 3},
                   {"p", "p", -3},
                   {"significant", "p < 0.05", 0},
                   {"result", "Result", 0},
                   {"note", "Note", 0}};
  const struct {
    std::string_view score;
    const char* unit;
  } parameters[] = {{kScoreMuS, ""}, {kScoreMuD, ""}, {kScoreKc, "N/mm"}, {kScoreKe, "N/mm"}};
  for (const auto& par : parameters) {
    std::vector<double> mild, severe;
    for (const auto& [who, trials] : people) {
      if (const Summary s = summarize(values_of(trials, par.score, kMild)); s.mean) mild.push_back(*s.mean);
      if (const Summary s = summarize(values_of(trials, par.score, kSevere)); s.mean)
        severe.push_back(*s.mean);
    }
    if (mild.empty() && severe.empty()) continue;
    const Anova a = one_way_anova({mild, severe});
    table.rows.push_back({text(std::string(par.score)), text(par.unit), number(summarize(mild).mean),
                          number(summarize(severe).mean), integer(mild.size()), integer(severe.size()),
                          real(a.ss_between), real(a.ss_within), integer(static_cast<std::size_t>(a.df1)),
                          integer(static_cast<std::size_t>(a.df2)), number(a.f), number(a.p),
                          a.p ? text(*a.p < 0.05 ? "yes" : "no") : Cell{}, text(result_text(a)),
                          text(a.note)});
  }
  return table;
}

// The boundary score (§4.2.2): points out of trials, and each shape's share named right.
ReportTable boundary_table(const Participants& people) {
  ReportTable table{"boundary",
                    "Boundary shapes (§4.2.2)",
                    "Per participant: one point per trial with all three shapes named right, and each "
                    "shape's share of trials named right; cohort: mean ± SD over participants (the paper: "
                    "7.2 ± 1.69 points out of 10 trials).",
                    {},
                    {}};
  table.columns = {{"participant", "Participant", 0}, {"trials", "Trials", 0}};
  add_mean_sd(table, "points", "Points", 2);
  add_mean_sd(table, "points_per_10", "Points per 10 trials", 2);
  // The shapes in the data, the paper's three first.
  std::vector<std::string> shapes;
  for (const char* s : {"square", "triangle", "circle"}) shapes.emplace_back(s);
  for (const auto& [who, trials] : people)
    for (const StudyTrial* t : trials)
      for (const TrialScore& s : t->scores)
        if (s.name == kScoreShapeCorrect && std::find(shapes.begin(), shapes.end(), s.level) == shapes.end())
          shapes.push_back(s.level);
  for (const std::string& shape : shapes) add_mean_sd(table, "shape_" + shape, "Named " + shape, 2);

  CohortColumns cohort(2 + shapes.size());
  std::size_t total = 0, participants = 0;
  for (const auto& [who, trials] : people) {
    const std::vector<const StudyTrial*> done =
        trials_with(trials, {kScoreBoundaryPoint, kScoreShapeCorrect});
    if (done.empty()) continue;
    ++participants;
    total += done.size();
    double points = 0.0;
    for (double v : values_of(done, kScoreBoundaryPoint, nullptr)) points += v;
    std::vector<Cell> row{text(who),
                          integer(done.size()),
                          real(points),
                          Cell{},
                          real(points * 10.0 / static_cast<double>(done.size())),
                          Cell{}};
    cohort.add(0, summarize({points}));
    cohort.add(1, summarize({points * 10.0 / static_cast<double>(done.size())}));
    for (std::size_t i = 0; i < shapes.size(); ++i) {
      const Summary s = summarize(values_of(done, kScoreShapeCorrect, shapes[i].c_str()));
      cohort.add(2 + i, s);
      row.push_back(number(s.mean));
      row.push_back(Cell{});
    }
    table.rows.push_back(std::move(row));
  }
  if (participants > 0) {
    std::vector<Cell> row{text(kCohort), integer(total)};
    for (std::size_t i = 0; i < 2 + shapes.size(); ++i) put_summary(row, cohort.summary(i));
    table.rows.push_back(std::move(row));
  }
  return table;
}

// The diagnosis exercise (§5.3): counts summed, rates and times mean ± SD over the participant's cases.
ReportTable diagnosis_table(const Participants& people) {
  ReportTable table{"diagnosis",
                    "Diagnosis (§5.3)",
                    "Per participant: lesions, detections, misses and false marks summed over the cases; "
                    "detection rate, severity accuracy and case time mean ± SD over the cases; time to "
                    "detection mean ± SD over the detected lesions (all, and by the lesion's severity). "
                    "Cohort: counts summed, the rest mean ± SD of the participant means.",
                    {},
                    {}};
  table.columns = {{"participant", "Participant", 0}, {"cases", "Cases", 0},
                   {"lesions", "Lesions", 0},         {"detected", "Detected", 0},
                   {"missed", "Missed", 0},           {"false_marks", "False marks", 0}};
  add_mean_sd(table, "detection_rate", "Detection rate", 2);
  add_mean_sd(table, "severity_accuracy", "Severity accuracy", 2);
  add_mean_sd(table, "time_to_detection_s", "Time to detection (s)", 1);
  add_mean_sd(table, "time_to_detection_mild_s", "Time to detection, mild (s)", 1);
  add_mean_sd(table, "time_to_detection_severe_s", "Time to detection, severe (s)", 1);
  add_mean_sd(table, "case_time_s", "Case time (s)", 1);
  const std::string_view counts[] = {kScoreLesions, kScoreDetected, kScoreMissed, kScoreFalseMarks};

  CohortColumns cohort(6);
  double sums[4] = {0, 0, 0, 0};
  std::size_t total = 0, participants = 0;
  for (const auto& [who, trials] : people) {
    std::vector<const StudyTrial*> cases;
    for (const StudyTrial* t : trials)
      if (t->kind == kKindDiagnosis) cases.push_back(t);
    if (cases.empty()) continue;
    ++participants;
    total += cases.size();
    std::vector<Cell> row{text(who), integer(cases.size())};
    for (std::size_t i = 0; i < 4; ++i) {
      double sum = 0.0;
      for (double v : values_of(cases, counts[i], nullptr)) sum += v;
      sums[i] += sum;
      row.push_back(real(sum));
    }
    const Summary summaries[] = {
        summarize(values_of(cases, kScoreDetectionRate, nullptr)),
        summarize(values_of(cases, kScoreSeverityAccuracy, nullptr)),
        summarize(values_of(cases, kScoreTimeToDetection, nullptr)),
        summarize(values_of(cases, kScoreTimeToDetection, kMild)),
        summarize(values_of(cases, kScoreTimeToDetection, kSevere)),
        summarize(values_of(cases, kScoreCaseTime, nullptr)),
    };
    for (std::size_t i = 0; i < 6; ++i) {
      cohort.add(i, summaries[i]);
      put_summary(row, summaries[i]);
    }
    table.rows.push_back(std::move(row));
  }
  if (participants > 0) {
    std::vector<Cell> row{text(kCohort), integer(total)};
    for (double s : sums) row.push_back(real(s));
    for (std::size_t i = 0; i < 6; ++i) put_summary(row, cohort.summary(i));
    table.rows.push_back(std::move(row));
  }
  return table;
}

// Soft-tissue damage, excess force on enamel and blocked insertions, over every trial that scores them.
ReportTable safety_table(const Participants& people) {
  ReportTable table{"safety",
                    "Soft-tissue damage and excess force",
                    "Per participant, mean ± SD per trial over the trials that score them: time pressing "
                    "gingiva or tongue beyond the threshold and its peak force, time over the excess force "
                    "on enamel and its peak; blocked insertions (wrong posture, Fig. 17b) summed. Cohort: "
                    "mean ± SD of the participant means, blocked insertions summed.",
                    {},
                    {}};
  table.columns = {{"participant", "Participant", 0}, {"trials", "Trials", 0}};
  const struct {
    std::string_view score;
    const char* key;
    const char* header;
  } scores[] = {{kScoreSoftTissueTime, "soft_tissue_time_s", "Soft-tissue time (s)"},
                {kScoreSoftTissuePeak, "soft_tissue_peak_N", "Soft-tissue peak (N)"},
                {kScoreEnamelExcessTime, "enamel_excess_time_s", "Enamel excess-force time (s)"},
                {kScoreEnamelPeak, "enamel_peak_N", "Enamel peak (N)"}};
  for (const auto& s : scores) add_mean_sd(table, s.key, s.header, 2);
  table.columns.push_back({"blocked_insertions", "Blocked insertions", 0});

  CohortColumns cohort(4);
  double blocked_total = 0.0;
  std::size_t total = 0, participants = 0;
  for (const auto& [who, trials] : people) {
    const std::vector<const StudyTrial*> scored =
        trials_with(trials, {kScoreSoftTissueTime, kScoreSoftTissuePeak, kScoreEnamelExcessTime,
                             kScoreEnamelPeak, kScoreBlockedInsertions});
    if (scored.empty()) continue;
    ++participants;
    total += scored.size();
    std::vector<Cell> row{text(who), integer(scored.size())};
    for (std::size_t i = 0; i < 4; ++i) {
      const Summary s = summarize(values_of(scored, scores[i].score, nullptr));
      cohort.add(i, s);
      put_summary(row, s);
    }
    double blocked = 0.0;
    for (double v : values_of(scored, kScoreBlockedInsertions, nullptr)) blocked += v;
    blocked_total += blocked;
    row.push_back(real(blocked));
    table.rows.push_back(std::move(row));
  }
  if (participants > 0) {
    std::vector<Cell> row{text(kCohort), integer(total)};
    for (std::size_t i = 0; i < 4; ++i) put_summary(row, cohort.summary(i));
    row.push_back(real(blocked_total));
    table.rows.push_back(std::move(row));
  }
  return table;
}

// Learning curves: per participant and kind of study, one score per trial in time order.
ReportTable learning_table(const Participants& people) {
  ReportTable table{"learning_curve",
                    "Learning curves, every trial",
                    "Per participant and kind of study, each trial in the order it started (index 1, 2, ...) "
                    "with its scores: shapes named right (0-3) for boundary shapes; detection rate, false "
                    "marks, case time and soft-tissue time for diagnosis.",
                    {},
                    {}};
  table.columns = {{"participant", "Participant", 0}, {"kind", "Kind", 0},       {"index", "Trial #", 0},
                   {"started_at", "Started", 0},      {"station", "Station", 0}, {"study", "Study", 0},
                   {"trial", "Study trial", 0},       {"score", "Score", 0},     {"value", "Value", 3}};
  for (const auto& [who, trials] : people) {
    std::map<std::string, std::size_t> index;
    for (const StudyTrial* t : trials) {
      std::vector<std::pair<std::string, std::optional<double>>> points;
      if (t->kind == kKindBoundary) {
        points.emplace_back("shapes_correct", trial_sum(*t, kScoreShapeCorrect));
      } else if (t->kind == kKindDiagnosis) {
        points.emplace_back(std::string(kScoreDetectionRate), trial_sum(*t, kScoreDetectionRate));
        points.emplace_back(std::string(kScoreFalseMarks), trial_sum(*t, kScoreFalseMarks));
        points.emplace_back(std::string(kScoreCaseTime), trial_sum(*t, kScoreCaseTime));
        points.emplace_back(std::string(kScoreSoftTissueTime), trial_sum(*t, kScoreSoftTissueTime));
      } else {
        continue;
      }
      const std::size_t i = ++index[t->kind];
      for (const auto& [score, value] : points) {
        if (!value) continue;
        table.rows.push_back({text(who), text(t->kind), integer(i), text(t->started_at), text(t->station),
                              text(t->study), id(t->trial), text(score), real(*value)});
      }
    }
  }
  return table;
}

// The learning curves summed up: per participant, kind and score, the first and last trial's value
// and the least-squares slope per trial.
ReportTable learning_summary_table(const ReportTable& curve) {
  ReportTable table{"learning_summary",
                    "Learning curves",
                    "Per participant, kind of study and score (learning_curve.csv holds every trial): the "
                    "trials, the first and the last trial's value, the mean, and the least-squares slope "
                    "of the value against the trial's index (change per trial; positive means rising).",
                    {},
                    {}};
  table.columns = {{"participant", "Participant", 0},
                   {"kind", "Kind", 0},
                   {"score", "Score", 0},
                   {"trials", "Trials", 0},
                   {"first", "First", 2},
                   {"last", "Last", 2},
                   {"mean", "Mean", 2},
                   {"slope_per_trial", "Slope per trial", 3}};
  // learning_table's columns: participant 0, kind 1, index 2, ..., score 7, value 8.
  std::map<std::tuple<std::string, std::string, std::string>,
           std::pair<std::vector<double>, std::vector<double>>>
      series;
  std::vector<std::tuple<std::string, std::string, std::string>> order;
  for (const std::vector<Cell>& row : curve.rows) {
    auto key = std::make_tuple(row[0].text, row[1].text, row[7].text);
    if (!series.count(key)) order.push_back(key);
    series[key].first.push_back(static_cast<double>(row[2].integer));
    series[key].second.push_back(row[8].number);
  }
  for (const auto& key : order) {
    const auto& [x, y] = series.at(key);
    table.rows.push_back({text(std::get<0>(key)), text(std::get<1>(key)), text(std::get<2>(key)),
                          integer(y.size()), real(y.front()), real(y.back()), number(summarize(y).mean),
                          number(least_squares_slope(x, y))});
  }
  return table;
}

// The inputs, the duplicates and the unfinished trials.
ReportTable inputs_table(const MergedStudies& merged) {
  ReportTable table{"inputs",
                    "Study databases",
                    "Each database given: its trial rows, how many finished, how many were left out as "
                    "copies of a row already counted.",
                    {},
                    {}};
  table.columns = {{"file", "File", 0},
                   {"trials", "Trials", 0},
                   {"finished", "Finished", 0},
                   {"unfinished", "Unfinished", 0},
                   {"duplicates", "Duplicates", 0},
                   {"note", "Note", 0}};
  for (const MergedStudies::Input& in : merged.inputs)
    table.rows.push_back({text(in.file), integer(in.trials), integer(in.finished),
                          integer(in.trials - in.finished), integer(in.duplicates),
                          text(in.same_file_again ? "the same file was given before: counted once" : "")});
  return table;
}

ReportTable duplicates_table(const MergedStudies& merged) {
  ReportTable table{"duplicates",
                    "Duplicate trial rows",
                    "Trial rows found more than once (same station, participant, study, trial, seed and "
                    "start): counted once. `differs` marks copies whose end time or scores disagree.",
                    {},
                    {}};
  table.columns = {{"kept", "Counted", 0}, {"dropped", "Left out", 0}, {"differs", "Differs", 0}};
  for (const DuplicateTrial& d : merged.duplicates)
    table.rows.push_back({text(d.kept), text(d.dropped), text(d.differs ? "yes" : "no")});
  return table;
}

ReportTable unfinished_table(const MergedStudies& merged) {
  ReportTable table{"unfinished",
                    "Unfinished trials",
                    "Trials without an end time (a crash or an abandoned case): listed, left out of every "
                    "statistic.",
                    {},
                    {}};
  table.columns = {{"file", "File", 0},         {"id", "Row", 0},
                   {"station", "Station", 0},   {"participant", "Participant", 0},
                   {"study", "Study", 0},       {"kind", "Kind", 0},
                   {"trial", "Trial", 0},       {"seed", "Seed", 0},
                   {"started_at", "Started", 0}};
  for (const StudyTrial& t : merged.unfinished)
    table.rows.push_back({text(t.file), id(t.id), text(t.station), text(t.participant), text(t.study),
                          text(t.kind), id(t.trial), id(t.seed), text(t.started_at)});
  return table;
}

// --- The gradebook (docs/reports.md, "The gradebook"): per trainee and case, in plain words. ---

// A trainee's finished diagnosis cases, in time order.
std::vector<const StudyTrial*> diagnosis_cases(const std::vector<const StudyTrial*>& trials) {
  std::vector<const StudyTrial*> out;
  for (const StudyTrial* t : trials)
    if (t->kind == kKindDiagnosis) out.push_back(t);
  return out;
}

// "1 false mark", "2 false marks".
std::string count_of(double n, const char* one, const char* many) {
  return fmt::format("{:g} {}", n, n == 1.0 ? one : many);
}

// What one case's scores say, in words a trainee understands.
std::string case_summary(const StudyTrial& t) {
  const double lesions = trial_sum(t, kScoreLesions).value_or(0.0);
  const double found = trial_sum(t, kScoreDetected).value_or(0.0);
  const double false_marks = trial_sum(t, kScoreFalseMarks).value_or(0.0);
  std::string out = fmt::format("Found {:g} of {:g} lesion{}", found, lesions, lesions == 1.0 ? "" : "s");
  if (const auto accuracy = trial_sum(t, kScoreSeverityAccuracy); accuracy && found > 0) {
    const double wrong = std::round(found - *accuracy * found);
    out += wrong > 0 ? fmt::format(" ({:g} graded wrong)", wrong) : std::string(" (all graded right)");
  }
  out +=
      "; " + (false_marks > 0 ? count_of(false_marks, "false mark", "false marks") : "no false marks") + ".";
  const auto soft = trial_sum(t, kScoreSoftTissueTime);
  if (soft && *soft > 0)
    out += fmt::format(" Pressed on gum or tongue for {:.2f} s (up to {:.1f} N).", *soft,
                       trial_sum(t, kScoreSoftTissuePeak).value_or(0.0));
  else if (soft)
    out += " Never pressed on gum or tongue.";
  const auto enamel = trial_sum(t, kScoreEnamelExcessTime);
  if (enamel && *enamel > 0)
    out += fmt::format(" Pushed healthy tooth harder than the force limit for {:.2f} s (up to {:.1f} N).",
                       *enamel, trial_sum(t, kScoreEnamelPeak).value_or(0.0));
  if (const auto blocked = trial_sum(t, kScoreBlockedInsertions); blocked && *blocked > 0)
    out += " " + count_of(*blocked, "push on caries", "pushes on caries") +
           " held off by the tool's posture (blocked).";
  return out;
}

// Per trainee and case: the counts, the times and force in seconds and newtons, and the summary.
ReportTable cases_table(const Participants& people) {
  ReportTable table{
      "cases",
      "Cases, per trainee",
      "Each trainee's diagnosis cases in the order they did them (case 1, 2, ...; the study "
      "trial is the case's number in its run): lesions found and missed, false "
      "marks, the mean time to find a lesion, soft-tissue damage and excess force, and a summary "
      "in words (the definitions above).",
      {},
      {}};
  table.section = kSectionGradebook;
  table.columns = {{"participant", "Trainee", 0},
                   {"station", "Station", 0},
                   {"study", "Study", 0},
                   {"case", "Case", 0},
                   {"trial", "Study trial", 0},
                   {"lesions", "Lesions", 0},
                   {"found", "Found", 0},
                   {"missed", "Missed", 0},
                   {"false_marks", "False marks", 0},
                   {"time_per_lesion_s", "Time per lesion (s)", 1},
                   {"case_time_s", "Case time (s)", 1},
                   {"soft_tissue_time_s", "Soft-tissue time (s)", 2},
                   {"enamel_excess_time_s", "Excess-force time (s)", 2},
                   {"summary", "In words", 0}};
  for (const auto& [who, trials] : people) {
    std::size_t index = 0;
    for (const StudyTrial* t : diagnosis_cases(trials)) {
      const Summary times = summarize(values_of({t}, kScoreTimeToDetection, nullptr));
      table.rows.push_back({text(who), text(t->station), text(t->study), integer(++index), id(t->trial),
                            number(trial_sum(*t, kScoreLesions)), number(trial_sum(*t, kScoreDetected)),
                            number(trial_sum(*t, kScoreMissed)), number(trial_sum(*t, kScoreFalseMarks)),
                            number(times.mean), number(trial_sum(*t, kScoreCaseTime)),
                            number(trial_sum(*t, kScoreSoftTissueTime)),
                            number(trial_sum(*t, kScoreEnamelExcessTime)), text(case_summary(*t))});
    }
  }
  return table;
}

// Per trainee, case and lesion: found or missed, the grade given, the time it was found; then the case's
// false marks. From the case's recorded lesions and marks (trials.answers); `unrecorded` counts the
// cases that lack them.
ReportTable lesions_table(const Participants& people, std::size_t& unrecorded) {
  ReportTable table{
      "lesions",
      "Lesions found and missed",
      "Each lesion of each case: where it was, its severity, whether the trainee found it (a mark "
      "in contact within the study's margin of it), the grade they gave and when; then each false "
      "mark of the case.",
      {},
      {}};
  table.section = kSectionGradebook;
  table.columns = {{"participant", "Trainee", 0}, {"case", "Case", 0},         {"lesion", "Lesion", 0},
                   {"site", "Site", 0},           {"severity", "Severity", 0}, {"result", "Result", 0},
                   {"marked_as", "Marked as", 0}, {"grade", "Grade", 0},       {"time_s", "Time (s)", 1}};
  unrecorded = 0;
  for (const auto& [who, trials] : people) {
    std::int64_t index = 0;
    for (const StudyTrial* t : diagnosis_cases(trials)) {
      ++index;  // the case's number in the cases table
      if (!t->diagnosis_case) {
        ++unrecorded;
        continue;
      }
      const RecordedCase& c = *t->diagnosis_case;
      for (std::size_t k = 0; k < c.lesions.size(); ++k) {
        const RecordedLesion& l = c.lesions[k];
        const auto first = std::find_if(c.marks.begin(), c.marks.end(), [&](const RecordedMark& m) {
          return m.first && m.lesion == static_cast<int>(k + 1);
        });
        if (first == c.marks.end()) {
          table.rows.push_back({text(who), id(index), integer(k + 1), text(l.site), text(l.severity),
                                text("missed"), Cell{}, Cell{}, Cell{}});
        } else {
          table.rows.push_back({text(who), id(index), integer(k + 1), text(l.site), text(l.severity),
                                text("found"), text(first->grade),
                                text(first->grade == l.severity ? "right" : "wrong"), real(first->t)});
        }
      }
      for (const RecordedMark& m : c.marks)
        if (m.lesion == 0)
          table.rows.push_back({text(who), id(index), Cell{}, Cell{}, Cell{},
                                text(m.contact ? "false mark" : "false mark (in the air)"), text(m.grade),
                                Cell{}, real(m.t)});
    }
  }
  return table;
}

// One graded measure: its key, its words, how a value compares with a criterion, the expert's figure.
struct Measure {
  const char* key;
  const char* definition;
  bool at_least;       // the criterion is a minimum (else a maximum)
  const char* unit;    // "" or " s"
  const char* expert;  // the paper's figure (§5.3), or ""
};
constexpr Measure kMeasures[] = {
    {"detection_rate", "lesions found / lesions, over all cases", true, "",
     "1 (the paper's expert found every lesion, §5.3)"},
    {"severity_accuracy", "found lesions graded right / found lesions", true, "", ""},
    {"false_marks", "most false marks in one case", false, "", ""},
    {"time_per_lesion", "mean time to find a lesion, over the found lesions", false, " s",
     "under 30 s per lesion (the paper's expert, §5.3)"},
    {"soft_tissue_time", "most time pressing on gum or tongue in one case", false, " s", ""},
};

// A trainee's values of kMeasures over their cases.
std::vector<std::optional<double>> measures_of(const std::vector<const StudyTrial*>& cases) {
  double lesions = 0, found = 0, right = 0;
  std::optional<double> most_false, most_soft;
  for (const StudyTrial* t : cases) {
    lesions += trial_sum(*t, kScoreLesions).value_or(0.0);
    const double f = trial_sum(*t, kScoreDetected).value_or(0.0);
    found += f;
    right += std::round(trial_sum(*t, kScoreSeverityAccuracy).value_or(0.0) * f);
    if (const auto v = trial_sum(*t, kScoreFalseMarks)) most_false = std::max(most_false.value_or(0.0), *v);
    if (const auto v = trial_sum(*t, kScoreSoftTissueTime)) most_soft = std::max(most_soft.value_or(0.0), *v);
  }
  const Summary times = summarize(values_of(cases, kScoreTimeToDetection, nullptr));
  return {lesions > 0 ? std::optional(found / lesions) : std::nullopt,
          found > 0 ? std::optional(right / found) : std::nullopt, most_false, times.mean, most_soft};
}

// The course's criteria in kMeasures' order.
std::vector<std::optional<double>> criteria_values(const PassCriteria* c) {
  if (c == nullptr) return std::vector<std::optional<double>>(std::size(kMeasures));
  return {c->detection_rate, c->severity_accuracy,
          c->false_marks ? std::optional<double>(*c->false_marks) : std::nullopt, c->time_per_lesion,
          c->soft_tissue_time};
}

// Pass/fail per trainee and criterion (gradebook.csv: what a school's gradebook imports), and per
// trainee in one line (`passed`). Without criteria the values and the expert's figures only.
std::pair<ReportTable, ReportTable> gradebook_tables(const Participants& people,
                                                     const PassCriteria* criteria) {
  ReportTable book{"gradebook",
                   "Gradebook: each trainee against each criterion",
                   "One row per trainee and criterion (gradebook.csv imports into a school's gradebook): the "
                   "trainee's value over their diagnosis cases, what the course requires, the paper's expert "
                   "for reference, and pass or fail; the row `overall` passes when every criterion does.",
                   {},
                   {}};
  book.section = kSectionGradebook;
  book.columns = {{"participant", "Trainee", 0},   {"criterion", "Criterion", 0},
                  {"definition", "Definition", 0}, {"value", "Value", 2},
                  {"required", "Required", 0},     {"expert", "Expert (paper)", 0},
                  {"result", "Result", 0},         {"note", "Note", 0}};
  ReportTable passed{
      "passed",
      "Who passed",
      "Per trainee: their diagnosis cases, the lesions found, and whether they met every criterion "
      "of the course (those not met are named).",
      {},
      {}};
  passed.section = kSectionGradebook;
  passed.columns = {{"participant", "Trainee", 0}, {"cases", "Cases", 0},   {"found", "Lesions found", 0},
                    {"lesions", "Lesions", 0},     {"result", "Result", 0}, {"not_met", "Not met", 0}};
  const std::vector<std::optional<double>> required = criteria_values(criteria);
  for (const auto& [who, trials] : people) {
    const std::vector<const StudyTrial*> cases = diagnosis_cases(trials);
    if (cases.empty()) continue;
    const std::vector<std::optional<double>> values = measures_of(cases);
    std::string not_met;
    for (std::size_t i = 0; i < std::size(kMeasures); ++i) {
      const Measure& m = kMeasures[i];
      Cell need, result, note;
      if (required[i]) {
        need = text(fmt::format("{} {:g}{}", m.at_least ? "at least" : "at most", *required[i], m.unit));
        const bool pass = values[i] && (m.at_least ? *values[i] >= *required[i] : *values[i] <= *required[i]);
        result = text(pass ? "pass" : "fail");
        if (!values[i]) note = text(i == 0 ? "no lesion in the cases" : "no lesion found");
        if (!pass) not_met += (not_met.empty() ? "" : ", ") + std::string(m.key);
      }
      book.rows.push_back({text(who), text(m.key), text(m.definition), number(values[i]), need,
                           text(m.expert), result, note});
    }
    double lesions = 0, found = 0;
    for (double v : values_of(cases, kScoreLesions, nullptr)) lesions += v;
    for (double v : values_of(cases, kScoreDetected, nullptr)) found += v;
    const Cell verdict = criteria ? text(not_met.empty() ? "pass" : "fail") : Cell{};
    if (criteria)
      book.rows.push_back({text(who), text("overall"), text("every criterion above met"), Cell{}, Cell{},
                           Cell{}, verdict, Cell{}});
    passed.rows.push_back(
        {text(who), integer(cases.size()), real(found), real(lesions), verdict, text(not_met)});
  }
  if (criteria == nullptr) passed.rows.clear();  // nothing to pass without criteria
  return {std::move(book), std::move(passed)};
}

// Every score the page shows, in one line each.
std::vector<Definition> definitions() {
  return {
      {"found / missed",
       "a lesion is found when the trainee marks it with the tool touching the tooth, within the "
       "study's margin (0.5 mm) of the lesion; only its first mark counts"},
      {"false mark", "a mark near no lesion (or made with the tool in the air)"},
      {"grade right / wrong", "whether the grade (mild or severe) of a lesion's first mark is its severity"},
      {"detection rate", "lesions found / lesions; the paper's expert found every lesion (1.0, §5.3)"},
      {"severity accuracy", "found lesions graded right / found lesions"},
      {"time to detection, time per lesion",
       "seconds from the start of the case to the mark that found a lesion; the paper's expert took under 30 "
       "s "
       "per lesion (§5.3)"},
      {"case time", "seconds until the trainee ended the case (or its time ran out)"},
      {"soft-tissue time",
       "seconds the tool pressed on gum or tongue harder than the threshold (1 N unless the "
       "study sets it): damage to soft tissue"},
      {"soft-tissue peak", "the largest force (N) on gum or tongue in the case"},
      {"excess-force time (enamel excess)",
       "seconds the tool pushed on healthy tooth harder than the force limit (4 N unless the study sets it): "
       "risk of damaging sound enamel"},
      {"enamel peak", "the largest force (N) on healthy tooth in the case"},
      {"blocked insertions",
       "pushes on caries that did not enter because the tool's posture was wrong (the shank "
       "against a neighbouring tooth, paper Fig. 17b)"},
      {"μs, μd", "static and dynamic friction the trainee tuned to feel like the lesion (Table 1)"},
      {"k_c, k_e", "penetration and contact stiffness (N/mm) the trainee tuned (Table 2)"},
      {"boundary points", "one point per trial with all three hidden shapes named right (§4.2.2)"},
      {"slope per trial",
       "the least-squares change of a score from one trial to the next (positive: rising)"},
      {"mean ± SD",
       "the mean over the trials and the sample standard deviation; cohort: over the trainees' means"},
  };
}

}  // namespace

Report build_report(MergedStudies merged, const PassCriteria* criteria) {
  Report report;
  const Participants people = by_participant(merged.finished);
  // The gradebook first (who passed, each case and lesion), then the research tables, then the inputs.
  report.definitions = definitions();
  report.graded = criteria != nullptr;
  auto [book, passed] = gradebook_tables(people, criteria);
  report.tables.push_back(std::move(passed));
  report.tables.push_back(std::move(book));
  report.tables.push_back(cases_table(people));
  std::size_t unrecorded = 0;
  report.tables.push_back(lesions_table(people, unrecorded));
  report.tables.push_back(tuning_table(
      people, "table1_roughness", "Table 1: tuned friction coefficients (§4.1.2)",
      "Per participant and level, mean ± SD of the tuned static and dynamic friction coefficients over "
      "their trials; cohort: mean ± SD of the participant means (the paper: mild μs 0.18 ± 0.07, "
      "μd 0.17 ± 0.06; severe μs 0.51 ± 0.16, μd 0.45 ± 0.15).",
      kScoreMuS, "μs", kScoreMuD, "μd", 2));
  report.tables.push_back(tuning_table(
      people, "table2_stiffness", "Table 2: tuned stiffness (§5.2)",
      "Per participant and level, mean ± SD of the tuned penetration stiffness k_c and contact stiffness "
      "k_e (N/mm) over their trials; cohort: mean ± SD of the participant means (the paper: mild k_c "
      "0.58 ± 0.10, k_e 0.53 ± 0.13; severe k_c 0.20 ± 0.06, k_e 0.38 ± 0.07).",
      kScoreKc, "k_c (N/mm)", kScoreKe, "k_e (N/mm)", 2));
  report.tables.push_back(anova_table(people));
  report.tables.push_back(boundary_table(people));
  report.tables.push_back(diagnosis_table(people));
  report.tables.push_back(safety_table(people));
  ReportTable curve = learning_table(people);
  curve.in_html = false;
  report.tables.push_back(learning_summary_table(curve));
  report.tables.push_back(std::move(curve));
  report.tables.push_back(inputs_table(merged));
  report.tables.push_back(unfinished_table(merged));
  report.tables.push_back(duplicates_table(merged));
  for (std::size_t i = report.tables.size() - 3; i < report.tables.size(); ++i)
    report.tables[i].section = kSectionInputs;

  // What a reader should know before reading the numbers.
  for (const MergedStudies::Input& in : merged.inputs) {
    if (in.same_file_again) report.warnings.push_back(in.file + ": given twice; counted once");
    if (in.pending > 0)
      report.warnings.push_back(
          in.file + ": " + std::to_string(in.pending) + " trial result(s) wait in " + in.file +
          "-pending (the database was locked when they ended) and are not in this report; "
          "they are merged when a study next runs on it");
  }
  if (!merged.duplicates.empty()) {
    std::size_t differing = 0;
    for (const DuplicateTrial& d : merged.duplicates) differing += d.differs ? 1 : 0;
    report.warnings.push_back(std::to_string(merged.duplicates.size()) +
                              " duplicate trial row(s) counted once" +
                              (differing ? " (" + std::to_string(differing) +
                                               " with a different end time or scores: the finished copy read "
                                               "first is counted)"
                                         : std::string()));
  }
  if (!merged.unfinished.empty())
    report.warnings.push_back(std::to_string(merged.unfinished.size()) +
                              " unfinished trial(s) listed and left out of the statistics");
  if (merged.finished.empty()) report.warnings.push_back("no finished trials: every table is empty");
  if (unrecorded > 0)
    report.warnings.push_back(std::to_string(unrecorded) +
                              " diagnosis case(s) recorded without their lesions and marks (answers): "
                              "counted, but not listed lesion by lesion");

  report.merged = std::move(merged);
  return report;
}

}  // namespace cariesim::training
