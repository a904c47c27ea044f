// Course files (training/course.hpp, docs/instructors.md): YAML -> Course, every field checked and
// located with the scene parser's strict reader.
#include "cariesim/training/course.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/training/study.hpp"

namespace cariesim::training {

namespace {

using io::Fields;
using io::Reader;

// A non-empty text field.
std::string required_text(const Reader& r, const Fields& f, std::string_view key) {
  const YAML::Node node = f.require(key);
  std::string value = r.text(node, f.sub(key));
  if (value.empty()) r.fail(node, f.sub(key), "must not be empty");
  return value;
}

// An identifier field (station, participant).
std::string identifier(const Reader& r, const YAML::Node& node, const std::string& path) {
  std::string value = r.text(node, path);
  if (!valid_identifier(value))
    r.fail(
        node, path,
        fmt::format("'{}' is not a valid name: 1-64 letters, digits, '.', '_' or '-', not starting with '.'",
                    value));
  return value;
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

}  // namespace

bool valid_identifier(std::string_view id) {
  if (id.empty() || id.size() > 64 || id.front() == '.') return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == '-';
  });
}

std::filesystem::path Course::database() const { return records / (station + ".db"); }

bool Course::allows(std::string_view id) const {
  if (!valid_identifier(id)) return false;
  return participants.empty() ||
         std::find(participants.begin(), participants.end(), id) != participants.end();
}

Course parse_course(std::string_view yaml, const std::filesystem::path& origin) {
  const Reader r(origin.string());
  Course course;
  course.file = origin;

  // One strict document (size, syntax, aliases: io::parse_document).
  const YAML::Node root = io::parse_document(yaml, origin.string());

  try {
    const Fields f(r, root, "",
                   {"format", "course", "study", "records", "station", "participants", "instructor"});
    if (const auto n = f.get("format"); n.IsDefined()) (void)r.integer_in(n, "format", 1, 1);
    course.name = required_text(r, f, "course");
    const std::filesystem::path base = origin.parent_path();

    // The study: a file (relative to the course file) that must exist, or a built-in name.
    const std::string study = required_text(r, f, "study");
    course.study_is_file =
        study.find('/') != std::string::npos || ends_with(study, ".yaml") || ends_with(study, ".yml");
    if (course.study_is_file) {
      const std::filesystem::path path = base / study;
      if (const io::FileKind kind = io::file_kind(path); kind == io::FileKind::Missing)
        r.fail(f.get("study"), "study", fmt::format("study file not found: {}", path.string()));
      else if (kind != io::FileKind::Regular)
        r.fail(
            f.get("study"), "study",
            fmt::format("{}: not a regular file ({}), not a study file", path.string(), io::describe(kind)));
      course.study = path.string();
    } else {
      const std::vector<std::string> names = builtin_study_names();
      if (std::find(names.begin(), names.end(), study) == names.end()) {
        std::string list;
        for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
        r.fail(f.get("study"), "study",
               fmt::format("no built-in study '{}' (built-ins: {}; a file ends in .yaml)", study, list));
      }
      course.study = study;
    }

    // Where the databases go, and this station.
    course.records = base / required_text(r, f, "records");
    course.station = identifier(r, f.require("station"), "station");

    // Participants allowed (optional): unique identifiers.
    if (const auto list = f.get("participants"); list.IsDefined() && !list.IsNull()) {
      r.require_sequence(list, "participants");
      for (std::size_t i = 0; i < list.size(); ++i) {
        const std::string path = io::indexed("participants", i);
        std::string id = identifier(r, list[i], path);
        if (std::find(course.participants.begin(), course.participants.end(), id) !=
            course.participants.end())
          r.fail(list[i], path, fmt::format("participant '{}' is listed twice", id));
        course.participants.push_back(std::move(id));
      }
    }

    // The instructor passphrase's hash, decoded now so a bad one is found before the class.
    const YAML::Node hash = f.require("instructor");
    course.instructor_hash = r.text(hash, "instructor");
    try {
      (void)parse_passphrase_hash(course.instructor_hash);
    } catch (const Error& e) {
      r.fail(hash, "instructor", e.what());
    }
  } catch (const YAML::Exception& e) {
    throw Error(fmt::format("{}: {}", r.where(e.mark), e.msg));
  }
  return course;
}

Course load_course(const std::filesystem::path& file) {
  return parse_course(io::read_file(file, "course"), file);
}

}  // namespace cariesim::training
