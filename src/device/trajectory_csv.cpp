#include "cariesim/device/trajectory_csv.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/device/input_guard.hpp"
#include "cariesim/io/file.hpp"

namespace cariesim {

namespace {

constexpr std::array<std::string_view, 8> kColumns{"t", "px", "py", "pz", "qw", "qx", "qy", "qz"};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

[[noreturn]] void fail(const std::string& origin, std::size_t line, std::size_t column,
                       const std::string& what) {
  throw Error(origin + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " + what);
}

// The parser's state across lines, so a file can be fed line by line (load_trajectory_csv) without
// holding its text, and a string all at once (parse_trajectory_csv) with the same rules.
class TrajectoryCsvParser {
 public:
  explicit TrajectoryCsvParser(std::string origin) : origin_(std::move(origin)) { index_.fill(-1); }

  // One line (without its newline), numbered from 1.
  void line(std::string_view line, std::size_t line_no) {
    // A UTF-8 byte order mark (spreadsheet exports write one) is not part of the first column's name.
    if (line_no == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);
    // Blank lines and '#' comments are skipped.
    if (trim(line).empty() || trim(line).front() == '#') return;

    // Split into fields, remembering each field's column.
    fields_.clear();
    std::size_t pos = 0;
    while (true) {
      const std::size_t comma = line.find(',', pos);
      fields_.emplace_back(trim(line.substr(pos, comma - pos)), pos + 1);
      if (comma == std::string_view::npos) break;
      pos = comma + 1;
    }

    // The header names the columns (any order; extra columns are ignored).
    if (!header_seen_) {
      for (std::size_t f = 0; f < fields_.size(); ++f)
        for (std::size_t c = 0; c < kColumns.size(); ++c)
          if (fields_[f].first == kColumns[c]) index_[c] = static_cast<int>(f);
      for (std::size_t c = 0; c < kColumns.size(); ++c)
        if (index_[c] < 0)
          fail(origin_, line_no, 1,
               "header lacks column '" + std::string(kColumns[c]) + "' (expected t,px,py,pz,qw,qx,qy,qz)");
      header_seen_ = true;
      field_count_ = fields_.size();
      return;
    }

    // A sample: every standard column must be a finite number.
    if (fields_.size() != field_count_)
      fail(origin_, line_no, 1,
           "expected " + std::to_string(field_count_) + " fields, found " + std::to_string(fields_.size()));
    std::array<double, kColumns.size()> v{};
    for (std::size_t c = 0; c < kColumns.size(); ++c) {
      const auto& [field, column] = fields_[index_[c]];
      double value = 0.0;
      const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
      if (ec != std::errc() || end != field.data() + field.size() || field.empty())
        fail(origin_, line_no, column,
             "column '" + std::string(kColumns[c]) + "': '" + std::string(field) + "' is not a number");
      if (!std::isfinite(value))
        fail(origin_, line_no, column, "column '" + std::string(kColumns[c]) + "' is not finite");
      v[c] = value;
    }
    if (!out_.t.empty() && !(v[0] > out_.t.back()))
      fail(origin_, line_no, fields_[index_[0]].second,
           "time " + std::string(fields_[index_[0]].first) + " s does not increase");
    // The input guard's rule, as for the UDP bridge: a unit quaternion (is_unit: within
    // kUnitTolerance, then normalised); another length is an error, not something to guess the
    // meaning of.
    Quat q(v[4], v[5], v[6], v[7]);
    if (!is_unit(q))
      fail(origin_, line_no, fields_[index_[4]].second,
           "quaternion (qw,qx,qy,qz) has length " + std::to_string(q.norm()) +
               "; a unit quaternion is expected (within " + std::to_string(kUnitTolerance) + ")");
    out_.add(v[0], Pose{Vec3(v[1], v[2], v[3]), q.normalized()});
  }

  // The trajectory, once every line was fed.
  Trajectory finish() {
    if (!header_seen_) throw Error(origin_ + ": empty trajectory (no header t,px,py,pz,qw,qx,qy,qz)");
    if (out_.empty()) throw Error(origin_ + ": trajectory has a header but no samples");
    return std::move(out_);
  }

 private:
  std::string origin_;
  Trajectory out_;
  std::array<int, kColumns.size()> index_{};
  bool header_seen_ = false;
  std::size_t field_count_ = 0;
  std::vector<std::pair<std::string_view, std::size_t>> fields_;
};

}  // namespace

Trajectory parse_trajectory_csv(std::string_view text, const std::string& origin) {
  TrajectoryCsvParser parser(origin);
  std::size_t line_no = 0;
  while (!text.empty()) {
    const std::size_t eol = text.find('\n');
    parser.line(text.substr(0, eol), ++line_no);
    text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
  }
  return parser.finish();
}

// Read line by line: memory holds the trajectory, never the file's text as well; the reader refuses
// what is no regular file and bounds the file and each line.
Trajectory load_trajectory_csv(const std::filesystem::path& file) {
  io::LineReader in(file, "trajectory (CSV t,px,py,pz,qw,qx,qy,qz)", kMaxTrajectoryBytes);
  TrajectoryCsvParser parser(file.string());
  std::string line;
  while (in.next(line)) parser.line(line, in.line_number());
  return parser.finish();
}

void save_trajectory_csv(const Trajectory& trajectory, const std::filesystem::path& file) {
  std::ofstream out(file);
  if (!out) throw Error(file.string() + ": cannot write trajectory file");
  out << "t,px,py,pz,qw,qx,qy,qz\n";
  out.precision(10);
  for (std::size_t i = 0; i < trajectory.t.size(); ++i) {
    const Pose& p = trajectory.pose[i];
    out << trajectory.t[i] << ',' << p.p.x() << ',' << p.p.y() << ',' << p.p.z() << ',' << p.q.w() << ','
        << p.q.x() << ',' << p.q.y() << ',' << p.q.z() << '\n';
  }
}

}  // namespace cariesim
