#include "cariesim/scene/trajectory.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "cariesim/common/error.hpp"

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

}  // namespace

Trajectory parse_trajectory_csv(std::string_view text, const std::string& origin) {
  Trajectory out;
  std::array<int, kColumns.size()> index{};
  index.fill(-1);
  std::size_t line_no = 0;
  bool header_seen = false;
  std::size_t field_count = 0;
  std::vector<std::pair<std::string_view, std::size_t>> fields;
  while (!text.empty()) {
    // Next line; blank lines and '#' comments are skipped.
    const std::size_t eol = text.find('\n');
    std::string_view line = text.substr(0, eol);
    text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 1);
    ++line_no;
    if (trim(line).empty() || trim(line).front() == '#') continue;

    // Split into fields, remembering each field's column.
    fields.clear();
    std::size_t pos = 0;
    while (true) {
      const std::size_t comma = line.find(',', pos);
      fields.emplace_back(trim(line.substr(pos, comma - pos)), pos + 1);
      if (comma == std::string_view::npos) break;
      pos = comma + 1;
    }

    // The header names the columns (any order; extra columns are ignored).
    if (!header_seen) {
      for (std::size_t f = 0; f < fields.size(); ++f)
        for (std::size_t c = 0; c < kColumns.size(); ++c)
          if (fields[f].first == kColumns[c]) index[c] = static_cast<int>(f);
      for (std::size_t c = 0; c < kColumns.size(); ++c)
        if (index[c] < 0)
          fail(origin, line_no, 1,
               "header lacks column '" + std::string(kColumns[c]) + "' (expected t,px,py,pz,qw,qx,qy,qz)");
      header_seen = true;
      field_count = fields.size();
      continue;
    }

    // A sample: every standard column must be a finite number.
    if (fields.size() != field_count)
      fail(origin, line_no, 1,
           "expected " + std::to_string(field_count) + " fields, found " + std::to_string(fields.size()));
    std::array<double, kColumns.size()> v{};
    for (std::size_t c = 0; c < kColumns.size(); ++c) {
      const auto& [field, column] = fields[index[c]];
      double value = 0.0;
      const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
      if (ec != std::errc() || end != field.data() + field.size() || field.empty())
        fail(origin, line_no, column,
             "column '" + std::string(kColumns[c]) + "': '" + std::string(field) + "' is not a number");
      if (!std::isfinite(value))
        fail(origin, line_no, column, "column '" + std::string(kColumns[c]) + "' is not finite");
      v[c] = value;
    }
    if (!out.t.empty() && !(v[0] > out.t.back()))
      fail(origin, line_no, fields[index[0]].second,
           "time " + std::string(fields[index[0]].first) + " s does not increase");
    Quat q(v[4], v[5], v[6], v[7]);
    if (q.norm() < 1e-6) fail(origin, line_no, fields[index[4]].second, "quaternion has zero length");
    out.add(v[0], Pose{Vec3(v[1], v[2], v[3]), q.normalized()});
  }
  if (!header_seen) throw Error(origin + ": empty trajectory (no header t,px,py,pz,qw,qx,qy,qz)");
  if (out.empty()) throw Error(origin + ": trajectory has a header but no samples");
  return out;
}

Trajectory load_trajectory_csv(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string() + ": cannot open trajectory file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_trajectory_csv(text.str(), file.string());
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
