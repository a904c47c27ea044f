#include "cariesim/io/yaml.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numbers>
#include <vector>

namespace cariesim::io {
namespace {

// Edit distance between two short keys, for "did you mean" hints.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// "a, b, c".
std::string join(std::initializer_list<std::string_view> names) {
  std::string out;
  for (const auto name : names) {
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out;
}

// A short description of what a node holds, for type errors.
std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsSequence()) return "a sequence";
  if (node.IsMap()) return "a mapping";
  std::string value = node.Scalar();
  if (value.size() > 40) value = value.substr(0, 37) + "...";
  return fmt::format("'{}'", value);
}

// True when `node` is `root` or lies inside it (keys included). Bounded by the node count the
// document passed (parse_document's kMaxYamlNodes).
bool contains(const YAML::Node& root, const YAML::Node& node) {
  if (!root.IsDefined() || !node.IsDefined()) return false;
  if (root.is(node)) return true;
  if (root.IsSequence()) {
    for (const YAML::Node& child : root)
      if (contains(child, node)) return true;
  } else if (root.IsMap()) {
    for (const auto& entry : root)
      if (contains(entry.first, node) || contains(entry.second, node)) return true;
  }
  return false;
}

// How many ancestors of a node are compared with it to name an alias inside its own anchor at once
// (a longer cycle is still stopped by kMaxYamlNodes).
constexpr std::size_t kCycleLookBack = 64;

// Walks the node graph with every alias expanded, counting nodes: refuses more than kMaxYamlNodes
// and an alias that names a node containing it. The walk keeps its own stack: aliases of aliases
// nest deeper than the text does.
void check_expansion(const Reader& r, const YAML::Node& root) {
  struct Frame {
    YAML::Node node;
    YAML::const_iterator next, end;
  };
  std::vector<Frame> path;
  std::uint64_t count = 1;
  const auto enter = [&](const YAML::Node& node) {
    if (!node.IsSequence() && !node.IsMap()) return;
    const std::size_t first = path.size() > kCycleLookBack ? path.size() - kCycleLookBack : 0;
    for (std::size_t i = first; i < path.size(); ++i)
      if (path[i].node.is(node))
        r.fail(node, "", "an alias names a node that contains it (an endless document)");
    path.push_back(Frame{node, node.begin(), node.end()});
  };
  enter(root);
  std::vector<YAML::Node> children;
  while (!path.empty()) {
    Frame& frame = path.back();
    if (frame.next == frame.end) {
      path.pop_back();
      continue;
    }
    children.clear();
    if (frame.node.IsMap()) {
      children.push_back(frame.next->first);
      children.push_back(frame.next->second);
    } else {
      children.push_back(*frame.next);
    }
    ++frame.next;
    for (const YAML::Node& child : children) {
      if (++count > kMaxYamlNodes)
        r.fail(child, "",
               fmt::format("the document expands to more than {} nodes through its aliases (a YAML bomb?)",
                           kMaxYamlNodes));
      enter(child);
    }
  }
}

}  // namespace

YAML::Node parse_document(std::string_view text, const std::string& origin, std::uintmax_t max_bytes) {
  const Reader r(origin);
  if (text.size() > max_bytes)
    throw Error(fmt::format("{}: too large ({} bytes, at most {})", origin, text.size(), max_bytes));
  // Syntax (and yaml-cpp's nesting bound): yaml-cpp's own errors, located.
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(std::string(text));
  } catch (const YAML::Exception& e) {
    throw Error(fmt::format("{}: YAML syntax error: {}", r.where(e.mark), e.msg));
  }
  if (documents.empty()) return YAML::Node(YAML::NodeType::Null);
  if (documents.size() > 1)
    r.fail(documents[1], "", "a second YAML document (after `---`): a file holds exactly one");
  check_expansion(r, documents.front());
  return documents.front();
}

NamedText builtin_or_file(const std::string& name_or_file, std::string_view what, std::string_view builtin,
                          const std::vector<std::string>& names, std::uintmax_t max_bytes) {
  if (!builtin.empty()) return NamedText{std::string(builtin), "builtin:" + name_or_file, true};
  // Not a built-in: a file, which must be there (else the built-ins are listed).
  if (file_kind(name_or_file) == FileKind::Missing) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw Error(
        fmt::format("{}: no such {} file, and not a built-in {} ({})", name_or_file, what, what, list));
  }
  return NamedText{read_file(name_or_file, what, max_bytes), name_or_file, false};
}

std::string Reader::where(const YAML::Mark& mark) const {
  if (mark.is_null() || mark.line < 0 || mark.column < 0) return fmt::format("{}:1:1", file_);
  return fmt::format("{}:{}:{}", file_, mark.line + 1, mark.column + 1);
}

std::string Reader::where(const YAML::Node& node) const {
  // A node placed from elsewhere (or inside one) is named by its label; only failures ask, so the
  // walk costs nothing on the way of a valid document.
  for (const auto& [placed, label] : placed_) {
    if (contains(placed, node)) return label;
  }
  return where(node.IsDefined() ? node.Mark() : YAML::Mark::null_mark());
}

void Reader::fail(const YAML::Node& node, const std::string& path, const std::string& message) const {
  if (path.empty()) throw Error(fmt::format("{}: {}", where(node), message));
  throw Error(fmt::format("{}: {}: {}", where(node), path, message));
}

double Reader::number(const YAML::Node& node, const std::string& path) const {
  // Plain (unquoted) scalars only; the whole text must be a finite decimal number.
  if (!node.IsDefined() || !node.IsScalar() || node.Tag() == "!") {
    fail(node, path, fmt::format("expected a number, got {}", describe(node)));
  }
  std::string_view text = node.Scalar();
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) {
    fail(node, path, fmt::format("expected a number, got {}", describe(node)));
  }
  if (!std::isfinite(value)) fail(node, path, "expected a finite number");
  return value;
}

double Reader::number_in(const YAML::Node& node, const std::string& path, double lo, double hi,
                         std::string_view unit) const {
  const double value = number(node, path);
  if (value < lo || value > hi) {
    fail(node, path,
         fmt::format("{} is out of range [{}, {}]{}{}", value, lo, hi, unit.empty() ? "" : " ", unit));
  }
  return value;
}

double Reader::positive(const YAML::Node& node, const std::string& path, double hi,
                        std::string_view unit) const {
  const double value = number(node, path);
  if (!(value > 0.0) || value > hi) {
    fail(node, path,
         fmt::format("{} is out of range: expected > 0 and <= {}{}{}", value, hi, unit.empty() ? "" : " ",
                     unit));
  }
  return value;
}

int64_t Reader::integer_in(const YAML::Node& node, const std::string& path, int64_t lo, int64_t hi) const {
  if (!node.IsDefined() || !node.IsScalar() || node.Tag() == "!") {
    fail(node, path, fmt::format("expected an integer, got {}", describe(node)));
  }
  std::string_view text = node.Scalar();
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  int64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) {
    fail(node, path, fmt::format("expected an integer, got {}", describe(node)));
  }
  if (value < lo || value > hi) fail(node, path, fmt::format("{} is out of range [{}, {}]", value, lo, hi));
  return value;
}

bool Reader::boolean(const YAML::Node& node, const std::string& path) const {
  if (node.IsDefined() && node.IsScalar() && node.Tag() != "!") {
    const std::string& s = node.Scalar();
    if (s == "true" || s == "True" || s == "yes") return true;
    if (s == "false" || s == "False" || s == "no") return false;
  }
  fail(node, path, fmt::format("expected true or false, got {}", describe(node)));
}

std::string Reader::text(const YAML::Node& node, const std::string& path) const {
  if (!node.IsDefined() || !node.IsScalar()) {
    fail(node, path, fmt::format("expected a text value, got {}", describe(node)));
  }
  return node.Scalar();
}

std::size_t Reader::choice(const YAML::Node& node, const std::string& path, std::string_view what,
                           std::initializer_list<std::string_view> names) const {
  const std::string value = text(node, path);
  std::size_t index = 0;
  for (const auto name : names) {
    if (value == name) return index;
    ++index;
  }
  fail(node, path, fmt::format("unknown {} '{}' (expected one of: {})", what, value, join(names)));
}

Vec3 Reader::vec3(const YAML::Node& node, const std::string& path) const {
  if (!node.IsDefined() || !node.IsSequence() || node.size() != 3) {
    fail(node, path, fmt::format("expected a sequence of 3 numbers, got {}", describe(node)));
  }
  Vec3 out;
  for (std::size_t i = 0; i < 3; ++i) out[static_cast<Eigen::Index>(i)] = number(node[i], indexed(path, i));
  return out;
}

Vec3 Reader::direction(const YAML::Node& node, const std::string& path) const {
  const Vec3 v = vec3(node, path);
  const double length = v.norm();
  if (!(length > 1e-9) || !std::isfinite(length)) fail(node, path, "expected a non-zero direction");
  return v / length;
}

Quat Reader::rotation(const YAML::Node& node, const std::string& path) const {
  const Fields fields(*this, node, path, {"axis", "angle"});
  const Vec3 axis = direction(fields.require("axis"), fields.sub("axis"));
  const double angle = number_in(fields.require("angle"), fields.sub("angle"), -720.0, 720.0, "degrees");
  constexpr double kDegree = std::numbers::pi / 180.0;  // rad per degree
  return Quat(Eigen::AngleAxisd(angle * kDegree, axis)).normalized();
}

Eigen::Vector2d Reader::vec2(const YAML::Node& node, const std::string& path) const {
  if (!node.IsDefined() || !node.IsSequence() || node.size() != 2) {
    fail(node, path, fmt::format("expected a sequence of 2 numbers, got {}", describe(node)));
  }
  return {number(node[0], indexed(path, 0)), number(node[1], indexed(path, 1))};
}

void Reader::require_sequence(const YAML::Node& node, const std::string& path) const {
  if (node.IsDefined() && !node.IsSequence()) {
    fail(node, path, fmt::format("expected a sequence, got {}", describe(node)));
  }
}

Fields::Fields(const Reader& reader, const YAML::Node& node, std::string path,
               std::initializer_list<std::string_view> allowed)
    : reader_(reader), node_(node), path_(std::move(path)) {
  // The node must be a mapping whose keys are distinct, known scalars.
  if (!node.IsDefined() || !node.IsMap()) {
    reader.fail(node, path_, fmt::format("expected a mapping, got {}", describe(node)));
  }
  for (auto it = node.begin(); it != node.end(); ++it) {
    const YAML::Node key = it->first;
    if (!key.IsScalar()) reader.fail(key, path_, "keys must be plain names");
    const std::string name = key.Scalar();
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      // Unknown key: suggest the closest allowed one when it is a likely typo.
      std::string_view best;
      std::size_t best_distance = 3;
      for (const auto candidate : allowed) {
        const std::size_t d = edit_distance(name, candidate);
        if (d < best_distance) {
          best_distance = d;
          best = candidate;
        }
      }
      const std::string hint = best.empty() ? "" : fmt::format("did you mean '{}'? ", best);
      reader.fail(key, sub(name), fmt::format("unknown key ({}expected one of: {})", hint, join(allowed)));
    }
    for (const auto& entry : entries_) {
      if (entry.first == name) reader.fail(key, sub(name), "duplicate key");
    }
    entries_.emplace_back(name, it->second);
  }
}

YAML::Node Fields::get(std::string_view key) const {
  for (const auto& entry : entries_) {
    if (entry.first == key) return entry.second;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

YAML::Node Fields::require(std::string_view key) const {
  for (const auto& entry : entries_) {
    if (entry.first == key) return entry.second;
  }
  reader_.fail(node_, sub(key), "missing required field");
}

bool Fields::has(std::string_view key) const { return get(key).IsDefined(); }

std::string Fields::sub(std::string_view key) const {
  return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
}

void Fields::number(std::string_view key, double& out) const {
  if (const YAML::Node n = get(key); n.IsDefined()) out = reader_.number(n, sub(key));
}

void Fields::positive(std::string_view key, double& out, double hi, std::string_view unit) const {
  if (const YAML::Node n = get(key); n.IsDefined()) out = reader_.positive(n, sub(key), hi, unit);
}

void Fields::number_in(std::string_view key, double& out, double lo, double hi, std::string_view unit) const {
  if (const YAML::Node n = get(key); n.IsDefined()) out = reader_.number_in(n, sub(key), lo, hi, unit);
}

std::string indexed(const std::string& path, std::size_t index) { return fmt::format("{}[{}]", path, index); }

}  // namespace cariesim::io
