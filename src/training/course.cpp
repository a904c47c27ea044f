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
    r.fail(node, path, fmt::format("'{}' is not a valid name: {}", value, kIdentifierRule));
  return value;
}

// Top-level folders of the system (the Filesystem Hierarchy Standard's, and the kernel's virtual ones)
// that a records folder may never be in, and the folders below them made for data.
constexpr std::string_view kSystemFolders[] = {"bin",    "boot", "dev", "etc",  "lib", "lib32", "lib64",
                                               "libx32", "proc", "run", "sbin", "sys", "usr",   "var"};
constexpr std::string_view kDataFolders[] = {"/var/tmp", "/var/lib", "/run/media"};

// The folder a course's `records` names, as the system will find it: absolute, `..` and the symbolic
// links that exist resolved, no trailing separator.
std::filesystem::path resolve_folder(const std::filesystem::path& folder) {
  std::error_code ec;
  std::filesystem::path out = std::filesystem::absolute(folder, ec);
  if (ec) out = folder;
  std::filesystem::path canonical = std::filesystem::weakly_canonical(out, ec);
  out = ec ? out.lexically_normal() : canonical.lexically_normal();
  while (out.has_relative_path() && !out.has_filename()) out = out.parent_path();
  return out;
}

// True when `folder` is `base` or lies below it (both absolute and normal).
bool within(const std::filesystem::path& folder, const std::filesystem::path& base) {
  const std::filesystem::path rel = folder.lexically_relative(base);
  return !rel.empty() && *rel.begin() != "..";
}

// Why `folder` (resolve_folder's) cannot hold study databases; empty when it can.
std::string records_problem(const std::filesystem::path& folder) {
  std::vector<std::string> parts;
  for (const auto& part : folder.relative_path()) parts.push_back(part.string());
  if (parts.empty()) return "the root folder";
  // Below a folder made for data: a folder of its own there, not the shared folder itself.
  for (const std::string_view data : kDataFolders) {
    if (!within(folder, data)) continue;
    if (folder == std::filesystem::path(data)) return fmt::format("the shared folder {}", data);
    return {};
  }
  if (std::find(std::begin(kSystemFolders), std::end(kSystemFolders), parts.front()) !=
      std::end(kSystemFolders))
    return fmt::format("inside the system folder /{}", parts.front());
  if (parts.size() == 1) return fmt::format("the top-level folder /{}", parts.front());
  return {};
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

// s: the longest time a criterion may name (a case is at most minutes long).
constexpr double kMaxCriterionSeconds = 1e4;

// The course's `criteria` mapping (docs/instructors.md): fractions in [0, 1], a whole count of false
// marks, times in seconds; an unknown key, a wrong type or a value out of range names its field.
PassCriteria parse_criteria(const Reader& r, const YAML::Node& node) {
  const Fields f(
      r, node, "criteria",
      {"detection_rate", "severity_accuracy", "false_marks", "time_per_lesion", "soft_tissue_time"});
  PassCriteria c;
  if (const auto n = f.get("detection_rate"); n.IsDefined())
    c.detection_rate = r.number_in(n, f.sub("detection_rate"), 0.0, 1.0, "");
  if (const auto n = f.get("severity_accuracy"); n.IsDefined())
    c.severity_accuracy = r.number_in(n, f.sub("severity_accuracy"), 0.0, 1.0, "");
  if (const auto n = f.get("false_marks"); n.IsDefined())
    c.false_marks = static_cast<int>(r.integer_in(n, f.sub("false_marks"), 0, 1000));
  if (const auto n = f.get("time_per_lesion"); n.IsDefined())
    c.time_per_lesion = r.positive(n, f.sub("time_per_lesion"), kMaxCriterionSeconds, "s");
  if (const auto n = f.get("soft_tissue_time"); n.IsDefined())
    c.soft_tissue_time = r.number_in(n, f.sub("soft_tissue_time"), 0.0, kMaxCriterionSeconds, "s");
  if (!c.detection_rate && !c.severity_accuracy && !c.false_marks && !c.time_per_lesion &&
      !c.soft_tissue_time)
    r.fail(node, "criteria",
           "no criterion given (detection_rate, severity_accuracy, false_marks, time_per_lesion, "
           "soft_tissue_time)");
  return c;
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
    const Fields f(
        r, root, "",
        {"format", "course", "study", "records", "station", "participants", "instructor", "criteria",
         "exam_seed"});
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

    // Where the databases go: a folder of its own, never the root, a top-level folder or a system
    // folder (after `..` and the symbolic links that exist are resolved).
    const std::string records = required_text(r, f, "records");
    course.records = base / records;
    {
      const std::filesystem::path resolved = resolve_folder(course.records);
      if (const std::string problem = records_problem(resolved); !problem.empty())
        r.fail(f.get("records"), "records",
               fmt::format("'{}' is {} ({}); give the study databases a folder of their own, e.g. `records: "
                           "records` beside the course file",
                           records, problem, resolved.string()));
    }
    course.station = identifier(r, f.require("station"), "station");

    // Participants allowed (optional): identifiers, then the first repeated one (first_repeated:
    // one hash-set lookup each, so a list of 100 000 is checked in linear time).
    if (const auto list = f.get("participants"); list.IsDefined() && !list.IsNull()) {
      r.require_sequence(list, "participants");
      std::vector<YAML::Node> items;
      items.reserve(list.size());
      for (const YAML::Node& item : list) {
        course.participants.push_back(
            identifier(r, item, io::indexed("participants", items.size())));
        items.push_back(item);
      }
      if (const std::size_t i = first_repeated(course.participants); i < items.size())
        r.fail(items[i], io::indexed("participants", i),
               fmt::format("participant '{}' is listed twice", course.participants[i]));
    }

    // An exam's seed (optional): decimal digits in [0, kMaxSeed], as a study file's `seed`.
    if (const auto n = f.get("exam_seed"); n.IsDefined()) {
      course.exam_seed = parse_seed(r.text(n, "exam_seed"));
      if (!course.exam_seed)
        r.fail(n, "exam_seed",
               fmt::format("expected a seed: an integer in [0, {}] in decimal digits", kMaxSeed));
    }

    // The instructor passphrase's hash, decoded now so a bad one is found before the class.
    const YAML::Node hash = f.require("instructor");
    course.instructor_hash = r.text(hash, "instructor");
    try {
      (void)parse_passphrase_hash(course.instructor_hash);
    } catch (const Error& e) {
      r.fail(hash, "instructor", e.what());
    }

    // What the report grades (optional): each criterion in its range, at least one given.
    if (const auto node = f.get("criteria"); node.IsDefined()) course.criteria = parse_criteria(r, node);
  } catch (const YAML::Exception& e) {
    throw Error(fmt::format("{}: {}", r.where(e.mark), e.msg));
  }
  return course;
}

Course load_course(const std::filesystem::path& file) {
  return parse_course(io::read_file(file, "course"), file);
}

}  // namespace cariesim::training
