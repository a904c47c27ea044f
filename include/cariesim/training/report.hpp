#pragma once
// `cariesim report DB... --out DIR` (docs/reports.md): merges the study databases of many stations
// (src/training/study_schema.hpp) and writes the class's tables as CSV, JSON and one self-contained
// HTML page: the paper's Tables 1-2 layout with the one-way ANOVA between levels (§4.1.2, §5.2), the
// boundary score (§4.2.2), the diagnosis accuracy and times (§5.3), soft-tissue damage and excess
// force, and learning curves.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/training/course.hpp"

namespace cariesim::training {

/// A lesion of a recorded diagnosis case (trials.answers "lesions", docs/training.md).
struct RecordedLesion {
  std::string site;      ///< the study's site name
  std::string severity;  ///< "mild" or "severe"
};

/// A mark of a recorded diagnosis case (trials.answers "marks").
struct RecordedMark {
  double t = 0.0;             ///< s, servo time from the trial's start
  std::string grade;          ///< "mild" or "severe"
  bool contact = false;       ///< the tool touched something
  double tip[3] = {0, 0, 0};  ///< mm, world: the graphic tool's tip
  int lesion = 0;             ///< the lesion it went to, from 1; 0: a false mark
  bool first = false;         ///< the lesion's first mark (the one that found it)
};

/// What a finished diagnosis trial's answers hold: the case's lesions and the trainee's marks.
struct RecordedCase {
  std::vector<RecordedLesion> lesions;
  std::vector<RecordedMark> marks;
};

/// One score of a trial (a row of the `scores` table).
struct TrialScore {
  std::string name;    ///< kScore* (study_schema.hpp)
  std::string level;   ///< "mild"/"severe", a shape name, or ""
  double value = 0.0;  ///< in `unit`
  std::string unit;    ///< "", "N/mm", "s", "N", "count", "fraction"
};

/// One trial row of a study database with its scores.
struct StudyTrial {
  std::string file;     ///< the database it was read from
  std::int64_t id = 0;  ///< trials.id in that database
  std::string station, participant, study, kind;
  std::int64_t trial = 0;  ///< trial number within the study run
  std::int64_t seed = 0;
  std::string started_at;               ///< ISO 8601 UTC
  std::optional<std::string> ended_at;  ///< empty for an unfinished trial
  std::vector<TrialScore> scores;
  /// A finished diagnosis trial's lesions and marks (trials.answers), when it records them.
  std::optional<RecordedCase> diagnosis_case;
};

/// Reads every trial of a study database, opened read-only. Throws cariesim::Error naming the file
/// when it cannot be opened or read, is not a study database (application id, tables) or has another
/// schema version than kStudySchemaVersion, or a finished diagnosis trial's answers are not what a
/// station writes (named by file, row, column and field).
std::vector<StudyTrial> read_study_database(const std::filesystem::path& file);

/// A trial row found more than once (in two copies of a database, or the same database twice).
struct DuplicateTrial {
  std::string kept;      ///< "FILE#id" of the row counted
  std::string dropped;   ///< "FILE#id" of the row left out
  bool differs = false;  ///< the two rows do not hold the same end time and scores
};

/// The trials of all databases, each counted once.
struct MergedStudies {
  struct Input {
    std::string file;
    std::size_t trials = 0;        ///< rows read
    std::size_t finished = 0;      ///< of them with ended_at
    std::size_t duplicates = 0;    ///< of them left out as duplicates
    bool same_file_again = false;  ///< the same file (after resolving links) was given before
    /// Trial results waiting beside it (run.hpp pending_folder: the database was locked when they
    /// ended); not in the database yet, so not in the report.
    std::size_t pending = 0;
  };
  std::vector<Input> inputs;
  std::vector<StudyTrial> finished;    ///< unique finished trials, by participant then start time
  std::vector<StudyTrial> unfinished;  ///< unique trials with ended_at NULL (not in the statistics)
  std::vector<DuplicateTrial> duplicates;
};

/// Reads and merges `files`. A trial is the same trial when station, participant, study, trial
/// number, seed and start time agree; of its copies the first finished one is kept. Throws
/// cariesim::Error (naming the file) on the first database that cannot be read.
MergedStudies merge_study_databases(const std::vector<std::filesystem::path>& files);

/// A cell of a report table: empty (a value that does not exist: CSV "", JSON null, HTML "–"),
/// text, an integer or a finite number. (A plain struct: GCC 12 warns falsely about std::variant
/// with a string member under -O2, -Wmaybe-uninitialized.)
struct Cell {
  enum class Kind { Empty, Text, Integer, Number };
  Kind kind = Kind::Empty;
  std::string text;
  std::int64_t integer = 0;
  double number = 0.0;  ///< finite when kind == Number

  static Cell of_text(std::string s);
  static Cell of_integer(std::int64_t i);
  /// A number; a non-finite one is an empty cell (the report never writes NaN).
  static Cell of_number(double d);
};

/// A column of a report table.
struct Column {
  std::string key;     ///< CSV header and JSON key
  std::string header;  ///< HTML header
  int decimals = 3;    ///< digits after the point in HTML, or significant digits when negative (CSV and
                       ///< JSON keep full precision)
};

/// The report's parts, in page order (docs/reports.md).
inline constexpr const char* kSectionGradebook = "Gradebook";
inline constexpr const char* kSectionResearch = "Research tables";
inline constexpr const char* kSectionInputs = "Inputs";

/// One table of the report, written as NAME.csv, under "NAME" in report.json and in report.html.
/// In HTML a column KEY_mean followed by KEY_sd is shown as one "mean ± SD" cell.
struct ReportTable {
  std::string name;     ///< file stem: "table1_roughness", ...
  std::string title;    ///< HTML heading
  std::string caption;  ///< what the table shows (HTML, JSON)
  std::vector<Column> columns;
  std::vector<std::vector<Cell>> rows;
  bool in_html = true;  ///< false: CSV and JSON only (a long-form table), the page names the file
  /// The part of the page it is in: kSectionGradebook, kSectionResearch or kSectionInputs ("": CSV
  /// and JSON only, not on the page). A table without rows is left off the page (its CSV and JSON
  /// entry stay, empty).
  std::string section = kSectionResearch;
};

/// A score's one-line definition, shown on the page.
struct Definition {
  std::string term;
  std::string meaning;
};

/// The whole report before it is written.
struct Report {
  MergedStudies merged;
  std::vector<ReportTable> tables;
  std::vector<std::string> warnings;  ///< duplicates, conflicting copies, unfinished trials, ...
  std::vector<Definition> definitions;  ///< every score the page shows, in words
  bool graded = false;                  ///< pass/fail criteria were given
};

/// Builds every table from merged studies; `criteria` (a course's, may be null) grades each trainee's
/// diagnosis cases pass or fail (the table `gradebook`, one row per trainee and criterion).
Report build_report(MergedStudies merged, const PassCriteria* criteria = nullptr);

/// Adds the data of the case pictures to `report`: the tables case_outlines (each tooth of each
/// study's scene seen from above) and case_points (each recorded case's lesions, placed as the model
/// places them, and marks), both CSV and JSON only, for the figures. Each case is rebuilt from its
/// study and recorded seed (make_trial); a study is one of `study_files` (by its name) or a built-in.
/// A case whose study is unknown or whose rebuilt lesions differ from the recorded ones keeps its
/// marks without lesions, and a warning says so. Returns the cases drawn.
std::size_t add_case_views(Report& report, const std::vector<std::string>& study_files);

/// Draws the report's figures from the CSV files in `dir` into PNG files there and returns their
/// paths (an empty list when it cannot draw; the report is written without figures then).
using FigureDrawer = std::function<std::vector<std::filesystem::path>(const std::filesystem::path& dir)>;

/// What write_report wrote.
struct ReportFiles {
  std::filesystem::path dir;
  std::vector<std::filesystem::path> files;  ///< CSVs, report.json, report.html, figures
  std::size_t figures = 0;                   ///< PNG figures embedded in report.html
};

/// Writes `report` into `out_dir`: NAME.csv per table, report.json, the figures `draw` makes and
/// report.html (inline CSS, figures as base64 PNG data URIs, no scripts or external files). All is
/// written into a staging folder beside `out_dir` first and moved into place only when complete, so
/// a failure leaves an earlier report as it was. Throws cariesim::Error naming the file on failure.
ReportFiles write_report(const Report& report, const std::filesystem::path& out_dir,
                         const FigureDrawer& draw);

/// RFC 4648 base64 of `bytes` (with '=' padding), as in an HTML data URI.
std::string base64_encode(const std::string& bytes);

}  // namespace cariesim::training
