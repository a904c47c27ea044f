// Writing a report (docs/reports.md): NAME.csv per table, report.json with every table, the figures
// and report.html, a single self-contained page (inline style, figures as base64 PNG data URIs, no
// script), all staged in a hidden sibling folder and moved into place when complete.
#include <fmt/format.h>
#include <unistd.h>

#include <boost/archive/iterators/base64_from_binary.hpp>
#include <boost/archive/iterators/transform_width.hpp>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "cariesim/common/clock.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/io/csv.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/json.hpp"
#include "cariesim/io/staged_folder.hpp"
#include "cariesim/training/report.hpp"

namespace cariesim::training {

namespace fs = std::filesystem;

std::string base64_encode(const std::string& bytes) {
  // Boost.Serialization's iterators regroup 8-bit bytes into 6-bit characters; the '=' padding to a
  // multiple of four characters is RFC 4648's and added here.
  using Encoder = boost::archive::iterators::base64_from_binary<
      boost::archive::iterators::transform_width<std::string::const_iterator, 6, 8>>;
  std::string out(Encoder(bytes.begin()), Encoder(bytes.end()));
  out.append((4 - out.size() % 4) % 4, '=');
  return out;
}

Cell Cell::of_text(std::string s) {
  Cell c;
  c.kind = Kind::Text;
  c.text = std::move(s);
  return c;
}

Cell Cell::of_integer(std::int64_t i) {
  Cell c;
  c.kind = Kind::Integer;
  c.integer = i;
  return c;
}

Cell Cell::of_number(double d) {
  Cell c;
  if (!std::isfinite(d)) return c;
  c.kind = Kind::Number;
  c.number = d;
  return c;
}

namespace {

void write_file(const fs::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw Error(file.string() + ": cannot write");
}

// Bytes: the largest figure (PNG) put into the page.
constexpr std::uintmax_t kMaxFigureBytes = std::uintmax_t{64} << 20;

// One cell through the CSV writer (io/csv.hpp: quoting, formula-leading text neutralised); an empty
// cell for a value that does not exist. Numbers in full (shortest round-trip) precision.
void csv_cell(io::CsvWriter& csv, const Cell& cell) {
  switch (cell.kind) {
    case Cell::Kind::Text:
      csv.text(cell.text);
      return;
    case Cell::Kind::Integer:
      csv.integer(cell.integer);
      return;
    case Cell::Kind::Number:
      if (std::isfinite(cell.number)) {
        csv.number(cell.number);
        return;
      }
      break;
    case Cell::Kind::Empty:
      break;
  }
  csv.empty();
}

// NAME.csv: the column keys, then each row.
void write_table_csv(const fs::path& file, const ReportTable& table) {
  io::CsvWriter csv(file);
  for (const Column& column : table.columns) csv.text(column.key);
  csv.end_row();
  for (const std::vector<Cell>& row : table.rows) {
    for (const Cell& cell : row) csv_cell(csv, cell);
    csv.end_row();
  }
  csv.close();
}

void json_cell(io::JsonWriter& json, const Cell& cell) {
  switch (cell.kind) {
    case Cell::Kind::Text:
      json.value(cell.text);
      return;
    case Cell::Kind::Integer:
      json.value(static_cast<long long>(cell.integer));
      return;
    case Cell::Kind::Number:
      json.value(cell.number);
      return;  // finite by construction
    case Cell::Kind::Empty:
      break;
  }
  json.null();
}

std::string html_escape(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string html_number(const Cell& cell, int decimals) {
  switch (cell.kind) {
    case Cell::Kind::Number:
      // decimals < 0: that many significant digits (p-values down to 1e-5 and below).
      return decimals < 0 ? fmt::format("{:.{}g}", cell.number, -decimals)
                          : fmt::format("{:.{}f}", cell.number, decimals);
    case Cell::Kind::Integer:
      return std::to_string(cell.integer);
    case Cell::Kind::Text:
      return html_escape(cell.text);
    case Cell::Kind::Empty:
      break;
  }
  return "–";
}

bool ends_with(const std::string& s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// A table in HTML: a KEY_mean column followed by KEY_sd is one "mean ± SD" cell.
std::string table_html(const ReportTable& table) {
  std::string out = "<section id=\"" + table.name + "\">\n<h3>" + html_escape(table.title) + "</h3>\n<p>" +
                    html_escape(table.caption) + " <span class=\"files\">(" + table.name +
                    ".csv)</span></p>\n";
  if (!table.in_html)
    return out + "<p class=\"files\">" + std::to_string(table.rows.size()) + " rows in " + table.name +
           ".csv and report.json.</p>\n</section>\n";
  auto pair_at = [&](std::size_t c) {
    const std::string& key = table.columns[c].key;
    return ends_with(key, "_mean") && c + 1 < table.columns.size() &&
           table.columns[c + 1].key == key.substr(0, key.size() - 5) + "_sd";
  };
  out += "<div class=\"scroll\"><table>\n<thead><tr>";
  for (std::size_t c = 0; c < table.columns.size(); ++c) {
    out += "<th>" + html_escape(table.columns[c].header) + "</th>";
    if (pair_at(c)) ++c;
  }
  out += "</tr></thead>\n<tbody>\n";
  for (const std::vector<Cell>& row : table.rows) {
    const bool cohort = !row.empty() && row[0].kind == Cell::Kind::Text && row[0].text == "cohort";
    out += cohort ? "<tr class=\"cohort\">" : "<tr>";
    for (std::size_t c = 0; c < table.columns.size() && c < row.size(); ++c) {
      const int decimals = table.columns[c].decimals;
      std::string text = html_number(row[c], decimals);
      if (pair_at(c)) {
        if (row[c + 1].kind != Cell::Kind::Empty) text += " ± " + html_number(row[c + 1], decimals);
        ++c;
      }
      out += "<td>" + text + "</td>";
    }
    out += "</tr>\n";
  }
  return out + "</tbody>\n</table></div>\n</section>\n";
}

// Where each figure goes (after which table) and what it shows.
struct FigurePlace {
  const char* stem;
  const char* after_table;
  const char* caption;
};
constexpr FigurePlace kFigurePlaces[] = {
    {"report-tuning", "anova",
     "Tuned values per participant (mean ± SD over their trials), mild against severe, with the cohort."},
    {"report-boundary", "boundary",
     "Boundary score per participant and the share of trials each shape was named right."},
    {"report-diagnosis", "diagnosis", "Detection rate and time to detection per participant."},
    {"report-cases", "lesions",
     "Each case seen from above: the teeth (drawn from the scene's meshes), the case's lesions (circles: "
     "blue "
     "mild, red severe, filled when found) and the trainee's marks (+ mild, x severe; green found a lesion, "
     "grey again on a found one, black false)."},
    {"report-learning", "learning_curve",
     "Learning curves: each participant's scores per trial, in time order."},
};

std::string figure_html(const fs::path& file, const char* caption) {
  return "<figure><img alt=\"" + html_escape(file.filename().string()) + "\" src=\"data:image/png;base64," +
         base64_encode(io::read_file(file, "figure", kMaxFigureBytes)) + "\"><figcaption>" +
         html_escape(caption) + " (" + html_escape(file.filename().string()) + ")</figcaption></figure>\n";
}

std::string report_html(const Report& report, const std::vector<fs::path>& figures,
                        const std::string& generated) {
  std::string out =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>cariesim "
      "report</title>\n"
      "<style>\n"
      "body{font-family:sans-serif;margin:2em;max-width:75em;color:#222}\n"
      "table{border-collapse:collapse;margin:0.5em 0 1.5em}\n"
      "th,td{border:1px solid #bbb;padding:0.25em 0.6em;text-align:right}\n"
      "td{white-space:nowrap}\n.scroll{overflow-x:auto}\n"
      "th:first-child,td:first-child{text-align:left}\n"
      "thead th{background:#eef}\n"
      "tr.cohort td{font-weight:bold;background:#f6f6f6}\n"
      ".warning{color:#a40}\n.files{color:#777;font-size:0.9em}\n.empty{color:#777}\n"
      "dt{font-weight:bold;margin-top:0.3em}\ndd{margin-left:1.5em}\n"
      "td:last-child{white-space:normal}\n"
      "figure{margin:1em 0}\nimg{max-width:100%}\nfigcaption{color:#555;font-size:0.9em}\n"
      "</style>\n</head>\n<body>\n<h1>cariesim report</h1>\n";
  out += "<p>" + std::to_string(report.merged.inputs.size()) + " database(s), " +
         std::to_string(report.merged.finished.size()) + " finished trial(s) counted, " +
         std::to_string(report.merged.unfinished.size()) + " unfinished. Generated " +
         html_escape(generated) + " by cariesim " + CARIESIM_VERSION +
         ". Every table is also NAME.csv and in report.json.</p>\n";
  if (!report.warnings.empty()) {
    out += "<ul>\n";
    for (const std::string& w : report.warnings) out += "<li class=\"warning\">" + html_escape(w) + "</li>\n";
    out += "</ul>\n";
  }
  // The parts in order, each with its tables that hold rows (an empty one is left off: its CSV and
  // JSON entry stay) and the figures drawn from them; the definitions after the gradebook.
  std::vector<bool> placed(figures.size(), false);
  for (const char* part : {kSectionGradebook, kSectionResearch, kSectionInputs}) {
    std::string body;
    for (const ReportTable& table : report.tables) {
      if (table.section != part || table.rows.empty()) continue;
      body += table_html(table);
      for (std::size_t i = 0; i < figures.size(); ++i)
        for (const FigurePlace& place : kFigurePlaces)
          if (!placed[i] && figures[i].stem().string().starts_with(place.stem) &&
              table.name == place.after_table) {
            body += figure_html(figures[i], place.caption);
            placed[i] = true;
          }
    }
    const bool gradebook = std::string_view(part) == kSectionGradebook;
    if (gradebook && !report.graded && !body.empty())
      body =
          "<p class=\"empty\">No pass/fail: the course gives no criteria (give <code>--course FILE</code> "
          "with a <code>criteria</code> section, docs/instructors.md).</p>\n" +
          body;
    if (!body.empty())
      out += "<section class=\"part\">\n<h2>" + html_escape(part) + "</h2>\n" + body + "</section>\n";
    if (gradebook) {
      out += "<section id=\"definitions\">\n<h2>What each score means</h2>\n<dl>\n";
      for (const Definition& d : report.definitions)
        out += "<dt>" + html_escape(d.term) + "</dt><dd>" + html_escape(d.meaning) + "</dd>\n";
      out += "</dl>\n</section>\n";
    }
  }
  for (std::size_t i = 0; i < figures.size(); ++i)
    if (!placed[i]) out += figure_html(figures[i], "Figure");
  if (figures.empty())
    out += "<p class=\"empty\">No figures: they need python3 with matplotlib (docs/reports.md).</p>\n";
  return out + "</body>\n</html>\n";
}

std::string report_json(const Report& report, const std::vector<fs::path>& figures,
                        const std::string& generated) {
  io::JsonWriter json;
  json.begin_object();
  json.field("generated_at", generated).field("version", CARIESIM_VERSION);
  json.key("warnings").begin_array();
  for (const std::string& w : report.warnings) json.value(w);
  json.end_array();
  json.key("figures").begin_array();
  for (const fs::path& f : figures) json.value(f.filename().string());
  json.end_array();
  json.field("graded", report.graded);
  json.key("definitions").begin_array();
  for (const Definition& d : report.definitions)
    json.begin_object().field("term", d.term).field("meaning", d.meaning).end_object();
  json.end_array();
  json.key("tables").begin_object();
  for (const ReportTable& table : report.tables) {
    json.key(table.name).begin_object();
    json.field("title", table.title).field("caption", table.caption);
    json.key("columns").begin_array();
    for (const Column& c : table.columns) json.value(c.key);
    json.end_array();
    json.key("rows").begin_array();
    for (const std::vector<Cell>& row : table.rows) {
      json.begin_object();
      for (std::size_t c = 0; c < table.columns.size() && c < row.size(); ++c) {
        json.key(table.columns[c].key);
        json_cell(json, row[c]);
      }
      json.end_object();
    }
    json.end_array();
    json.end_object();
  }
  json.end_object();
  json.end_object();
  return json.str() + "\n";
}

}  // namespace

ReportFiles write_report(const Report& report, const fs::path& out_dir, const FigureDrawer& draw) {
  io::StagedFolder staged(out_dir, "report");
  const fs::path& dir = staged.staging();
  const std::string generated = utc_now_iso8601();

  // The tables as CSV, then the figures drawn from them, then JSON and HTML.
  for (const ReportTable& table : report.tables) write_table_csv(dir / (table.name + ".csv"), table);
  std::vector<fs::path> figures;
  if (draw) {
    std::error_code ec;
    for (const fs::path& f : draw(dir)) {
      const fs::path file = f.is_absolute() ? f : dir / f;
      if (file.extension() == ".png" && fs::is_regular_file(file, ec)) figures.push_back(file);
    }
  }
  write_file(dir / "report.json", report_json(report, figures, generated));
  write_file(dir / "report.html", report_html(report, figures, generated));

  // Into place: the whole folder by one rename when the target is new, otherwise file by file.
  ReportFiles result;
  result.dir = staged.target();
  result.figures = figures.size();
  result.files = staged.publish();
  return result;
}

}  // namespace cariesim::training
