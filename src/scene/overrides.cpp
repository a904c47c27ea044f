// Parameter overrides (docs/scene-format.md, "Overrides"): "KEY=VALUE" read into a path and a YAML
// value, and placed into a scene's document before the reader sees it, so that an overridden value
// passes the checks a file's value does.

#include "overrides.hpp"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {

namespace {

// Bytes: the longest override value (a k_c profile or a pose fits in far less).
constexpr std::uintmax_t kMaxOverrideBytes = 64 * 1024;
// Steps: the deepest key path (the deepest scene field is five steps down).
constexpr std::size_t kMaxPathSteps = 16;

// One step of a key path: a mapping key or a sequence index.
struct Step {
  std::string name;       // the key, when not an index
  std::size_t index = 0;  // the index, when `is_index`
  bool is_index = false;
  std::string path;  // the key path up to and including this step
};

bool name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-'; }

// "lesions[0].material.k_c" -> lesions, [0], material, k_c. Throws naming the key and the column.
std::vector<Step> parse_path(std::string_view key, std::string_view context) {
  const auto bad = [&](std::size_t at, std::string_view what) {
    throw Error(
        fmt::format("{}: key '{}', character {}: {} (expected a path such as "
                    "lesions[0].material.k_c)",
                    context, key, at + 1, what));
  };
  std::vector<Step> steps;
  std::size_t i = 0;
  std::string so_far;
  bool expect_name = true;
  while (i < key.size() || expect_name) {
    if (steps.size() >= kMaxPathSteps) bad(i, fmt::format("more than {} steps", kMaxPathSteps));
    if (expect_name) {
      const std::size_t start = i;
      while (i < key.size() && name_char(key[i])) ++i;
      if (i == start) bad(i, "expected a field name");
      Step step;
      step.name = std::string(key.substr(start, i - start));
      so_far += (so_far.empty() ? "" : ".") + step.name;
      step.path = so_far;
      steps.push_back(std::move(step));
      expect_name = false;
    } else if (key[i] == '.') {
      ++i;
      expect_name = true;
    } else if (key[i] == '[') {
      const std::size_t close = key.find(']', i);
      if (close == std::string_view::npos) bad(i, "'[' without ']'");
      const std::string_view digits = key.substr(i + 1, close - i - 1);
      Step step;
      step.is_index = true;
      const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), step.index);
      if (digits.empty() || ec != std::errc() || end != digits.data() + digits.size())
        bad(i + 1, fmt::format("'{}' is not an index (0, 1, ...)", digits));
      so_far += fmt::format("[{}]", step.index);
      step.path = so_far;
      steps.push_back(std::move(step));
      i = close + 1;
    } else {
      bad(i, fmt::format("unexpected '{}'", key[i]));
    }
  }
  return steps;
}

// What a node holds, for messages about a path that does not fit the document.
std::string_view kind_of(const YAML::Node& node) {
  if (node.IsMap()) return "a mapping";
  if (node.IsSequence()) return "a sequence";
  if (node.IsScalar()) return "a scalar";
  return "empty";
}

// The mapping's key node named `name`, or an undefined node.
YAML::Node find_key(const YAML::Node& map, const std::string& name) {
  for (const auto& entry : map) {
    if (entry.first.IsScalar() && entry.first.Scalar() == name) return entry.first;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

// Places one override into `root`.
void apply_one(YAML::Node& root, const SceneOverride& o, io::Reader& reader) {
  const std::string label = fmt::format("{} (override {})", reader.file(), o.key);
  const std::vector<Step> steps = parse_path(o.key, label);
  const YAML::Node value = io::parse_document(o.value, label, kMaxOverrideBytes);
  if (!root.IsMap()) throw Error(fmt::format("{}: the scene is not a mapping", label));

  // Walk down the existing nodes; `current` is rebound with reset() (assignment would overwrite).
  YAML::Node current;
  current.reset(root);
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const Step& step = steps[s];
    const bool last = s + 1 == steps.size();
    const std::string parent = s == 0 ? "the scene" : steps[s - 1].path;
    if (step.is_index) {
      // A sequence entry: it must exist (an override changes entries, it does not add them).
      if (!current.IsSequence())
        throw Error(fmt::format("{}: {} is {}, not a sequence", label, parent, kind_of(current)));
      if (step.index >= current.size())
        throw Error(fmt::format("{}: {} has {} entr{} (indices from 0)", label, parent, current.size(),
                                current.size() == 1 ? "y" : "ies"));
      YAML::Node child = current[step.index];
      if (last) {
        child = value;  // the entry now holds the override's node
        reader.locate_as(child, label);
        return;
      }
      current.reset(child);
      continue;
    }
    // A mapping key: descend when present; when absent, create the rest of the path below it.
    if (!current.IsMap())
      throw Error(fmt::format("{}: {} is {}, not a mapping", label, parent, kind_of(current)));
    const YAML::Node key = find_key(current, step.name);
    if (key.IsDefined()) {
      YAML::Node child = current[key];
      if (last) {
        child = value;
        reader.locate_as(child, label);
        return;
      }
      if (child.IsNull()) {
        // `device:` with nothing under it: the rest of the path goes there.
        child = YAML::Node(YAML::NodeType::Map);
        reader.locate_as(child, label);
      }
      current.reset(child);
      continue;
    }
    // Absent: new mappings down to the value (an index below a missing key cannot exist).
    YAML::Node subtree;
    subtree.reset(value);
    for (std::size_t t = steps.size() - 1; t > s; --t) {
      if (steps[t].is_index)
        throw Error(fmt::format("{}: {} is not in the scene, so it has no entry {}", label, steps[t - 1].path,
                                steps[t].index));
      YAML::Node map(YAML::NodeType::Map);
      map[YAML::Node(steps[t].name)] = subtree;
      subtree.reset(map);
    }
    // The reader refuses an unknown key at this key node, located as the override.
    YAML::Node new_key(step.name);
    current[new_key] = subtree;
    reader.locate_as(new_key, label);
    reader.locate_as(subtree, label);
    return;
  }
}

}  // namespace

namespace scene_detail {

void apply_overrides(YAML::Node& root, std::span<const SceneOverride> overrides, io::Reader& reader) {
  for (const SceneOverride& o : overrides) apply_one(root, o, reader);
}

}  // namespace scene_detail

SceneOverride parse_override(std::string_view assignment) {
  // KEY=VALUE, split at the first '='; the key is checked here, the value by the scene's reader.
  const std::string context = fmt::format("--set '{}'", assignment);
  const std::size_t eq = assignment.find('=');
  if (eq == std::string_view::npos) throw Error(context + ": expected KEY=VALUE");
  std::string_view key = assignment.substr(0, eq);
  while (!key.empty() && std::isspace(static_cast<unsigned char>(key.front())) != 0) key.remove_prefix(1);
  while (!key.empty() && std::isspace(static_cast<unsigned char>(key.back())) != 0) key.remove_suffix(1);
  (void)parse_path(key, context);
  return SceneOverride{std::string(key), std::string(assignment.substr(eq + 1))};
}

std::string override_scene_text(std::string_view yaml, const std::filesystem::path& origin,
                                std::span<const SceneOverride> overrides) {
  // Checked as a scene first (located errors), then placed into the document and emitted.
  (void)parse_scene(yaml, origin, overrides);
  YAML::Node root = io::parse_document(yaml, origin.string());
  io::Reader reader(origin.string());
  scene_detail::apply_overrides(root, overrides, reader);
  YAML::Emitter out;
  out << root;
  if (!out.good())
    throw Error(fmt::format("{}: cannot write the scene: {}", origin.string(), out.GetLastError()));
  return std::string(out.c_str()) + "\n";
}

}  // namespace cariesim
