// Tree cache files (docs/design.md §3: "a cache hit loads in milliseconds").
//
// Layout, little-endian, no padding between fields:
//   magic "CSTREE\r\n" (8 bytes), version (u32, kTreeCacheVersion), key (u64),
//   mode (u8), levels (i32),
//   node count (u64) + nodes (32 bytes each: centre 3 x f32, radius f32, first u32, count u16,
//   material u16, leaf u32, flags u32),
//   leaf count (u64) + leaf_nodes (u32 each) + leaf_depth (f32 each),
//   leaf count (u64) + leaf tangents (2 normals of 3 x f32, count u8, wall mask u8, 2 bytes zero:
//   28 bytes each; since version 3),
//   vertex count (u64) + vertices (3 x f32 each), triangle count (u64) + triangles (3 x u32 each),
//   FNV-1a 64 of every byte before it (u64).
// Anything that does not read back exactly (short file, wrong magic, version or key, counts that
// overrun the file, checksum mismatch, a tree that fails check_tree, a triangle index out of range)
// makes the entry unusable: it is removed and the caller rebuilds.

#include "cariesim/spheretree/cache.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <type_traits>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/spheretree/build.hpp"

namespace cariesim {

namespace {

static_assert(std::endian::native == std::endian::little, "the cache format is little-endian");

// A SphereNode as stored (Eigen's vector is not trivially copyable, so nodes are copied field by field).
struct StoredNode {
  float center[3];
  float radius;
  uint32_t first;
  uint16_t count;
  uint16_t material;
  uint32_t leaf;
  uint32_t flags;
};
static_assert(sizeof(StoredNode) == 32, "stored nodes are 32 bytes");

// A leaf's tangents as stored.
struct StoredTangents {
  float normal[2][3] = {{0, 0, 0}, {0, 0, 0}};
  uint8_t count = 0;
  uint8_t wall_mask = 0;
  uint8_t pad[2] = {0, 0};
};
static_assert(sizeof(StoredTangents) == 28, "stored tangents are 28 bytes");

constexpr char kMagic[8] = {'C', 'S', 'T', 'R', 'E', 'E', '\r', '\n'};
// Bytes: the largest entry read back (a tree of the finest scan is tens of MB).
constexpr std::uintmax_t kMaxEntryBytes = std::uintmax_t{1} << 30;

// Appends raw bytes of values to a buffer.
class Writer {
 public:
  template <typename T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    put_bytes(&value, sizeof(T));
  }
  template <typename T>
  void put_array(const std::vector<T>& values) {
    put<uint64_t>(values.size());
    put_bytes(values.data(), values.size() * sizeof(T));
  }
  void put_bytes(const void* data, std::size_t size) {
    const auto* p = static_cast<const char*>(data);
    buffer_.insert(buffer_.end(), p, p + size);
  }
  [[nodiscard]] const std::vector<char>& buffer() const { return buffer_; }

 private:
  std::vector<char> buffer_;
};

// Reads raw values back; every read checks the remaining length.
class Reader {
 public:
  Reader(const char* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  bool get(T& value) {
    return get_bytes(&value, sizeof(T));
  }
  template <typename T>
  bool get_array(std::vector<T>& values) {
    uint64_t count = 0;
    if (!get(count) || count > (size_ - pos_) / sizeof(T)) return false;
    values.resize(count);
    return get_bytes(values.data(), count * sizeof(T));
  }
  bool get_bytes(void* out, std::size_t size) {
    if (size > size_ - pos_) return false;
    std::memcpy(out, data_ + pos_, size);
    pos_ += size;
    return true;
  }
  [[nodiscard]] std::size_t position() const { return pos_; }

 private:
  const char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

// The entry of a key: named by the key and the cache version together, so that builds of another
// version sharing the folder keep their own entries instead of replacing each other's.
std::filesystem::path entry_path(const std::filesystem::path& dir, uint64_t key) {
  const uint64_t name =
      BuildKey().add(static_cast<int64_t>(kTreeCacheVersion)).add(static_cast<int64_t>(key)).value();
  return dir / fmt::format("{:016x}.tree", name);
}

// Parses a whole file; returns false for anything unusable.
bool parse(std::string_view bytes, uint64_t key, CachedPart& part) {
  constexpr std::size_t kChecksumSize = sizeof(uint64_t);
  if (bytes.size() < sizeof(kMagic) + kChecksumSize) return false;
  const std::size_t body = bytes.size() - kChecksumSize;
  uint64_t stored_checksum = 0;
  std::memcpy(&stored_checksum, bytes.data() + body, kChecksumSize);
  if (fnv1a(kFnvOffset, bytes.data(), body) != stored_checksum) return false;

  Reader in(bytes.data(), body);
  char magic[sizeof(kMagic)] = {};
  uint32_t version = 0;
  uint64_t stored_key = 0;
  uint8_t mode = 0;
  int32_t levels = 0;
  if (!in.get_bytes(magic, sizeof(magic)) || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) return false;
  if (!in.get(version) || version != kTreeCacheVersion || !in.get(stored_key) || stored_key != key)
    return false;
  if (!in.get(mode) || mode > static_cast<uint8_t>(TreeMode::Octree) || !in.get(levels)) return false;
  SphereTree& tree = part.tree;
  tree.mode = static_cast<TreeMode>(mode);
  tree.levels = levels;
  std::vector<StoredNode> nodes;
  std::vector<std::array<float, 3>> vertices;
  std::vector<StoredTangents> tangents;
  if (!in.get_array(nodes) || !in.get_array(tree.leaf_nodes) || !in.get_array(tree.leaf_depth) ||
      !in.get_array(tangents) || tangents.size() != tree.leaf_nodes.size() || !in.get_array(vertices) || !in.get_array(part.display.triangles) || in.position() != body) {
    return false;
  }
  tree.nodes.resize(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const StoredNode& s = nodes[i];
    SphereNode& n = tree.nodes[i];
    n.center = Vec3f(s.center[0], s.center[1], s.center[2]);
    n.radius = s.radius;
    n.first = s.first;
    n.count = s.count;
    n.material = s.material;
    n.leaf = s.leaf;
    n.flags = s.flags;
  }
  tree.leaf_tangents.resize(tangents.size());
  for (std::size_t i = 0; i < tangents.size(); ++i) {
    const StoredTangents& t = tangents[i];
    if (t.count > 2) return false;
    LeafTangents& out = tree.leaf_tangents[i];
    for (int k = 0; k < 2; ++k) out.normal[k] = Vec3f(t.normal[k][0], t.normal[k][1], t.normal[k][2]);
    out.count = t.count;
    out.wall_mask = t.wall_mask;
  }
  part.display.vertices.resize(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    part.display.vertices[i] = Vec3f(vertices[i][0], vertices[i][1], vertices[i][2]);
  }
  for (const auto& t : part.display.triangles) {
    for (uint32_t v : t) {
      if (v >= vertices.size()) return false;
    }
  }
  return check_tree(tree).empty();
}

}  // namespace

TreeCache::TreeCache(std::filesystem::path dir) : dir_(std::move(dir)) {}

std::filesystem::path TreeCache::default_dir() {
  if (const char* env = std::getenv("CARIESIM_CACHE_DIR"); env && *env) return env;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return std::filesystem::path(xdg) / "cariesim";
  if (const char* home = std::getenv("HOME"); home && *home) {
    return std::filesystem::path(home) / ".cache" / "cariesim";
  }
  std::error_code ec;
  const auto tmp = std::filesystem::temp_directory_path(ec);
  return (ec ? std::filesystem::path("/tmp") : tmp) / "cariesim-cache";
}

std::optional<CachedPart> TreeCache::load(uint64_t key) const {
  const std::filesystem::path path = entry_path(dir_, key);
  std::error_code ec;
  if (io::file_kind(path) == io::FileKind::Missing) return std::nullopt;
  // A regular file of a bounded size (io::read_file); anything else there is passed over.
  std::string bytes;
  try {
    bytes = io::read_file(path, "tree cache entry", kMaxEntryBytes);
  } catch (const Error& e) {
    spdlog::warn("tree cache: ignoring {}", e.what());
    return std::nullopt;
  }
  CachedPart part;
  if (!parse(bytes, key, part)) {
    spdlog::warn("tree cache: ignoring unreadable entry {}", path.string());
    std::filesystem::remove(path, ec);
    return std::nullopt;
  }
  return part;
}

// Serialises into memory, writes a uniquely named temporary file beside the entry, then renames it
// over the entry (atomic on POSIX), so readers never see half a file.
void TreeCache::store(uint64_t key, const CachedPart& part) const {
  Writer out;
  out.put_bytes(kMagic, sizeof(kMagic));
  out.put(kTreeCacheVersion);
  out.put(key);
  out.put(static_cast<uint8_t>(part.tree.mode));
  out.put(static_cast<int32_t>(part.tree.levels));
  std::vector<StoredNode> nodes(part.tree.nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const SphereNode& n = part.tree.nodes[i];
    nodes[i] = {
        {n.center.x(), n.center.y(), n.center.z()}, n.radius, n.first, n.count, n.material, n.leaf, n.flags};
  }
  out.put_array(nodes);
  out.put_array(part.tree.leaf_nodes);
  out.put_array(part.tree.leaf_depth);
  std::vector<StoredTangents> tangents(part.tree.leaf_nodes.size());
  for (std::size_t i = 0; i < tangents.size() && i < part.tree.leaf_tangents.size(); ++i) {
    const LeafTangents& t = part.tree.leaf_tangents[i];
    for (int k = 0; k < 2; ++k)
      for (int a = 0; a < 3; ++a) tangents[i].normal[k][a] = t.normal[k][a];
    tangents[i].count = t.count;
    tangents[i].wall_mask = t.wall_mask;
  }
  out.put_array(tangents);
  std::vector<std::array<float, 3>> vertices(part.display.vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Vec3f& v = part.display.vertices[i];
    vertices[i] = {v.x(), v.y(), v.z()};
  }
  out.put_array(vertices);
  out.put_array(part.display.triangles);
  const uint64_t checksum = fnv1a(kFnvOffset, out.buffer().data(), out.buffer().size());
  out.put(checksum);

  static std::atomic<uint64_t> counter{0};
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) {
    spdlog::warn("tree cache: cannot create {}: {}", dir_.string(), ec.message());
    return;
  }
  const std::filesystem::path target = entry_path(dir_, key);
  std::filesystem::path temp = target;
  temp += fmt::format(".{}.{}.tmp", static_cast<long>(::getpid()), counter.fetch_add(1));
  {
    std::ofstream file(temp, std::ios::binary | std::ios::trunc);
    file.write(out.buffer().data(), static_cast<std::streamsize>(out.buffer().size()));
    file.close();
    if (!file) {
      spdlog::warn("tree cache: cannot write {}", temp.string());
      std::filesystem::remove(temp, ec);
      return;
    }
  }
  std::filesystem::rename(temp, target, ec);
  if (ec) {
    spdlog::warn("tree cache: cannot move {} into place: {}", temp.string(), ec.message());
    std::filesystem::remove(temp, ec);
  }
}

}  // namespace cariesim
