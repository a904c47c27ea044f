#pragma once
// Strict, located reading of every YAML document cariesim reads (scenes, studies, courses, answers):
// parse_document opens one (bounded, one document, aliases bounded, syntax errors located), and
// every accessor checks the type and range of what it reads and throws cariesim::Error
// "file:line:column: field.path: message".

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/common/math.hpp"
#include "cariesim/io/file.hpp"

namespace cariesim::io {

/// Most nodes a document may hold, counting each alias as the nodes it stands for: a "billion laughs"
/// document (aliases of aliases) or an alias inside its own anchor is refused before anything walks it.
inline constexpr std::uint64_t kMaxYamlNodes = std::uint64_t{1} << 22;

/// Parses `text` as one YAML document, strictly: at most `max_bytes` bytes; exactly one document (a
/// second one after `---` is refused, not ignored); syntax errors and yaml-cpp's nesting bound
/// (DeepRecursion) located as "origin:line:column: YAML syntax error: ..."; at most kMaxYamlNodes
/// nodes with aliases expanded, and no alias inside the node it names. An empty text gives a null
/// node. Throws cariesim::Error naming `origin`.
YAML::Node parse_document(std::string_view text, const std::string& origin,
                          std::uintmax_t max_bytes = kMaxTextBytes);

/// The text of a document named by a built-in name or a file path (scenes, studies), and the origin
/// its messages name ("builtin:NAME" or the path).
struct NamedText {
  std::string text;
  std::filesystem::path origin;
  bool builtin = false;
};

/// `builtin` is the built-in text named `name_or_file` (empty when none is), `names` every built-in's
/// name. A built-in wins; otherwise the file is read through read_file (a regular file of at most
/// `max_bytes`). Nothing there: "NAME: no such WHAT file, and not a built-in WHAT (a, b, c)".
NamedText builtin_or_file(const std::string& name_or_file, std::string_view what, std::string_view builtin,
                          const std::vector<std::string>& names, std::uintmax_t max_bytes = kMaxTextBytes);

/// Formats and throws errors located at a node.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  /// "file:line:column" of a node (1-based; 1:1 when yaml-cpp has no position).
  [[nodiscard]] std::string where(const YAML::Node& node) const;
  /// "file:line:column" of a mark.
  [[nodiscard]] std::string where(const YAML::Mark& mark) const;
  /// Throws "file:line:column: path: message" located at `node`.
  [[noreturn]] void fail(const YAML::Node& node, const std::string& path, const std::string& message) const;

  /// A finite number (plain scalar).
  [[nodiscard]] double number(const YAML::Node& node, const std::string& path) const;
  /// A number in [lo, hi]; `unit` is named in the message.
  [[nodiscard]] double number_in(const YAML::Node& node, const std::string& path, double lo, double hi,
                                 std::string_view unit) const;
  /// A number > 0 and <= hi.
  [[nodiscard]] double positive(const YAML::Node& node, const std::string& path, double hi,
                                std::string_view unit) const;
  /// An integer in [lo, hi].
  [[nodiscard]] int64_t integer_in(const YAML::Node& node, const std::string& path, int64_t lo,
                                   int64_t hi) const;
  /// true/false.
  [[nodiscard]] bool boolean(const YAML::Node& node, const std::string& path) const;
  /// Any scalar as text.
  [[nodiscard]] std::string text(const YAML::Node& node, const std::string& path) const;
  /// One of `names` (returns its index).
  [[nodiscard]] std::size_t choice(const YAML::Node& node, const std::string& path, std::string_view what,
                                   std::initializer_list<std::string_view> names) const;
  /// A sequence of 3 finite numbers.
  [[nodiscard]] Vec3 vec3(const YAML::Node& node, const std::string& path) const;
  /// A sequence of 3 finite numbers with a non-zero length, normalized.
  [[nodiscard]] Vec3 direction(const YAML::Node& node, const std::string& path) const;
  /// A rotation as scenes and device profiles write it: {axis: [x, y, z] (any non-zero length),
  /// angle: degrees in [-720, 720]} (right-hand rule).
  [[nodiscard]] Quat rotation(const YAML::Node& node, const std::string& path) const;
  /// A sequence of 2 finite numbers.
  [[nodiscard]] Eigen::Vector2d vec2(const YAML::Node& node, const std::string& path) const;
  /// Checks that `node` is a sequence (a missing node is an empty sequence).
  void require_sequence(const YAML::Node& node, const std::string& path) const;

  [[nodiscard]] const std::string& file() const { return file_; }

  /// Names `label` instead of "file:line:column" for `node`, and for every node inside it: a node that
  /// came from elsewhere than the file (a parameter override, scene/scene.hpp).
  void locate_as(const YAML::Node& node, std::string label) { placed_.emplace_back(node, std::move(label)); }

 private:
  std::string file_;
  std::vector<std::pair<YAML::Node, std::string>> placed_;
};

/// The keys of one mapping, checked against the allowed set: a non-mapping, a non-scalar key, a
/// duplicate or an unknown key (with a "did you mean" hint) throws at construction.
class Fields {
 public:
  Fields(const Reader& reader, const YAML::Node& node, std::string path,
         std::initializer_list<std::string_view> allowed);

  /// The value of `key`, or an undefined node when absent.
  [[nodiscard]] YAML::Node get(std::string_view key) const;
  /// The value of `key`; throws "path.key: missing required field" when absent.
  [[nodiscard]] YAML::Node require(std::string_view key) const;
  [[nodiscard]] bool has(std::string_view key) const;
  /// "path.key" (or "key" at the top level).
  [[nodiscard]] std::string sub(std::string_view key) const;
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const YAML::Node& node() const { return node_; }

  /// Optional typed readers: leave `out` unchanged when the key is absent.
  void number(std::string_view key, double& out) const;
  void positive(std::string_view key, double& out, double hi, std::string_view unit) const;
  void number_in(std::string_view key, double& out, double lo, double hi, std::string_view unit) const;

 private:
  const Reader& reader_;
  YAML::Node node_;
  std::string path_;
  std::vector<std::pair<std::string, YAML::Node>> entries_;
};

/// "items[3]".
std::string indexed(const std::string& path, std::size_t index);

}  // namespace cariesim::io
