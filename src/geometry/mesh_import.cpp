#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cstring>
#include <string_view>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/io/file.hpp"
#include "geometry/mesh_checks.hpp"

namespace cariesim {

namespace {

// Bytes of a binary STL: 80-byte header, 4-byte count, 50 bytes per triangle.
constexpr std::uint64_t kStlHeaderBytes = 84;
constexpr std::uint64_t kStlTriangleBytes = 50;

[[noreturn]] void fail(const std::string& what, const std::string& problem) {
  throw Error(fmt::format("{}: {}", what, problem));
}

enum class Format { Stl, Obj, Ply };

Format format_of(const std::filesystem::path& file, const std::string& what) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".stl") return Format::Stl;
  if (ext == ".obj") return Format::Obj;
  if (ext == ".ply") return Format::Ply;
  fail(what, fmt::format("unsupported mesh format '{}' (expected .stl, .obj or .ply)", ext));
}

// The file's bytes through io::read_file (a regular file of at most kMaxMeshFileBytes, else its kind
// or size is named), then not empty.
std::string read_bytes(const std::filesystem::path& file, const std::string& what) {
  std::string bytes = io::read_file(file, "mesh", kMaxMeshFileBytes);
  if (bytes.empty()) fail(what, "empty file (0 bytes)");
  return bytes;
}

// An ASCII STL starts with "solid" and its first kilobyte is printable text.
bool looks_like_ascii_stl(std::string_view bytes) {
  std::size_t i = 0;
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i]))) ++i;
  if (bytes.substr(i, 5) != "solid") return false;
  const std::size_t n = std::min<std::size_t>(bytes.size(), 1024);
  for (std::size_t k = 0; k < n; ++k) {
    const auto c = static_cast<unsigned char>(bytes[k]);
    if (!(std::isprint(c) || std::isspace(c))) return false;
  }
  return true;
}

// Checks a binary STL's size against its declared triangle count (assimp would otherwise reject a
// truncated file with a vague message, or misread a count whose 32-bit size wraps around). Trailing
// bytes after the last triangle are cut off with a warning. Returns the bytes to hand to assimp.
std::string_view check_stl(std::string_view bytes, const std::string& what, MeshReport& report) {
  const std::uint64_t size = bytes.size();
  std::uint32_t declared = 0;
  if (size >= kStlHeaderBytes) std::memcpy(&declared, bytes.data() + 80, sizeof(declared));
  const std::uint64_t expected = kStlHeaderBytes + kStlTriangleBytes * declared;
  if (size >= kStlHeaderBytes && size == expected) {
    if (declared == 0) fail(what, "no triangles: the binary STL header declares 0 triangles");
    return bytes;
  }
  if (looks_like_ascii_stl(bytes)) {
    // assimp tests the binary layout first with 32-bit arithmetic; refuse a text file that fools it.
    const auto wrapped = static_cast<std::uint32_t>(kStlHeaderBytes + kStlTriangleBytes * declared);
    if (size >= kStlHeaderBytes && wrapped == static_cast<std::uint32_t>(size)) {
      fail(what, "invalid STL: text file whose bytes 80-83 read as an inconsistent triangle count");
    }
    return bytes;
  }
  if (size < kStlHeaderBytes) {
    fail(what,
         fmt::format("truncated binary STL: {} bytes, shorter than the 84-byte header (or not an STL file)",
                     size));
  }
  if (size < expected) {
    fail(what,
         fmt::format("truncated binary STL: the header declares {} triangles ({} bytes) but the file has {} "
                     "bytes (or it is not an STL file)",
                     declared, expected, size));
  }
  if (declared == 0) fail(what, "no triangles: the binary STL header declares 0 triangles");
  report.warnings.push_back(
      fmt::format("ignored {} bytes after the last of {} triangles", size - expected, declared));
  return bytes.substr(0, static_cast<std::size_t>(expected));
}

// Checks a PLY header strictly (assimp's reader loops forever on some damaged headers) and its
// element counts against the bytes that follow it, so that a damaged count is reported as truncation
// instead of making the reader allocate for billions of elements.
void check_ply(std::string_view bytes, const std::string& what) {
  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::uint64_t min_bytes = 0;  // per element: scalar sizes plus list-count sizes
    std::uint64_t properties = 0;
  };
  auto type_bytes = [](const std::string& t) -> std::uint64_t {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32")
      return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
  };
  auto bad_line = [&](std::size_t number, std::string_view line, const char* why) {
    const std::string shown(line.substr(0, 60));
    fail(what, fmt::format("invalid PLY header, line {}: {} ('{}')", number, why, shown));
  };

  // Header lines up to "end_header", each one of the known keywords.
  std::vector<Element> elements;
  bool binary = false;
  bool have_format = false;
  std::size_t pos = 0;
  std::size_t number = 0;
  std::size_t body = std::string_view::npos;
  while (pos < bytes.size() && body == std::string_view::npos) {
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string_view::npos) eol = bytes.size();
    std::string_view line = bytes.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = eol + 1;
    ++number;
    std::istringstream words{std::string(line)};
    std::string key;
    words >> key;
    if (number == 1) {
      if (line != "ply") bad_line(number, line, "the first line must be 'ply'");
    } else if (key == "format") {
      std::string kind;
      std::string version;
      words >> kind >> version;
      if (kind != "ascii" && kind != "binary_little_endian" && kind != "binary_big_endian") {
        bad_line(number, line, "unknown format");
      }
      binary = kind != "ascii";
      have_format = true;
    } else if (key == "comment" || key == "obj_info") {
      continue;
    } else if (key == "element") {
      Element e;
      words >> e.name >> e.count;
      if (!words) bad_line(number, line, "expected 'element NAME COUNT'");
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) bad_line(number, line, "property before any element");
      std::string type;
      std::string item;
      std::string name;
      words >> type;
      if (type == "list") {
        words >> type >> item >> name;  // an empty list stores only its count
        if (!words || type_bytes(item) == 0)
          bad_line(number, line, "expected 'property list TYPE TYPE NAME'");
      } else {
        words >> name;
      }
      if (!words || type_bytes(type) == 0) bad_line(number, line, "unknown property type");
      elements.back().min_bytes += type_bytes(type);
      elements.back().properties += 1;
    } else if (line == "end_header") {
      body = pos;
    } else {
      bad_line(number, line, "unexpected line");
    }
  }
  if (body == std::string_view::npos) fail(what, "invalid PLY: the header has no end_header line");
  if (!have_format) fail(what, "invalid PLY: the header has no format line");
  body = std::min(body, bytes.size());
  const std::uint64_t body_bytes = bytes.size() - body;

  // ASCII holds one element per line.
  if (!binary) {
    std::uint64_t declared = 0;
    for (const auto& e : elements) {
      if (e.count > body_bytes + 1) {
        fail(what,
             fmt::format("truncated PLY: the header declares {} '{}' elements but only {} bytes follow it",
                         e.count, e.name, body_bytes));
      }
      declared += e.count;
    }
    const auto newlines = std::count(bytes.begin() + static_cast<std::ptrdiff_t>(body), bytes.end(), '\n');
    const auto lines =
        static_cast<std::uint64_t>(newlines) + (body_bytes > 0 && bytes.back() != '\n' ? 1 : 0);
    if (lines < declared) {
      fail(what, fmt::format("truncated PLY: the header declares {} elements but only {} lines follow it",
                             declared, lines));
    }
  }
  // Binary needs the scalar bytes of every element.
  if (binary) {
    std::uint64_t needed = 0;
    for (const auto& e : elements) {
      if (e.min_bytes > 0 && e.count > body_bytes / e.min_bytes) {
        fail(what,
             fmt::format("truncated PLY: the header declares {} '{}' elements but only {} bytes follow it",
                         e.count, e.name, body_bytes));
      }
      needed += e.min_bytes * e.count;
    }
    if (needed > body_bytes) {
      fail(what,
           fmt::format("truncated PLY: the header declares {} bytes of elements but only {} bytes follow it",
                       needed, body_bytes));
    }
  }
}

}  // namespace

TriangleMesh load_mesh(const std::filesystem::path& file, MeshReport* report,
                       const MeshLoadOptions& options) {
  const std::string what = file.string();
  if (!std::isfinite(options.scale) || options.scale <= 0.0) {
    fail(what, fmt::format("invalid scale {} (must be finite and positive)", options.scale));
  }
  MeshReport local;
  // What the path names first (a folder or FIFO is named as such, whatever its extension).
  (void)io::require_regular_file(file, "mesh", kMaxMeshFileBytes);
  const Format format = format_of(file, what);
  const std::string bytes = read_bytes(file, what);

  // Our own checks of what assimp accepts silently or reports vaguely.
  std::string_view input = bytes;
  const char* hint = "stl";
  if (format == Format::Stl) input = check_stl(bytes, what, local);
  if (format == Format::Obj) hint = "obj";
  if (format == Format::Ply) {
    hint = "ply";
    check_ply(bytes, what);
  }

  // Parse with assimp, without post-processing: Debian's assimp is built with assertions that abort
  // the process when an importer hands inconsistent data to a post-processing step (a truncated
  // ASCII PLY made aiProcess_Triangulate abort), and we must never crash. So polygons are fanned into
  // triangles and vertices welded here, with every index checked first.
  Assimp::Importer importer;
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFileFromMemory(input.data(), input.size(), 0, hint);
  } catch (const std::exception& e) {
    fail(what, fmt::format("cannot be read (invalid file): {}", e.what()));
  }
  if (scene == nullptr)
    fail(what, fmt::format("cannot be read (invalid file): {}", importer.GetErrorString()));

  // Gather every mesh into one, scaled to millimetres; indices checked, coordinates finite (named by
  // triangle and corner of the imported data).
  TriangleMesh out;
  std::size_t other_primitives = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if (mesh == nullptr || (mesh->mNumFaces > 0 && (mesh->mFaces == nullptr || mesh->mVertices == nullptr))) {
      fail(what, "cannot be read (invalid file): the reader returned an incomplete mesh");
    }
    const auto base = static_cast<uint32_t>(out.vertices.size());
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices < 3 || face.mIndices == nullptr) {
        ++other_primitives;
        continue;
      }
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        const unsigned v = face.mIndices[k];
        if (v >= mesh->mNumVertices) {
          fail(what,
               fmt::format("invalid file: face {} refers to vertex {} of {}", f, v, mesh->mNumVertices));
        }
        const aiVector3D& p = mesh->mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
          fail(what,
               fmt::format("non-finite coordinate (NaN or infinity) in triangle {} (corner {}): ({}, {}, {})",
                           out.triangles.size(), std::min(k, 2u), p.x, p.y, p.z));
        }
      }
      // Fan polygons (assimp's importers give triangles for STL, and usually for OBJ and PLY).
      for (unsigned k = 1; k + 1 < face.mNumIndices; ++k) {
        out.triangles.push_back(
            {base + face.mIndices[0], base + face.mIndices[k], base + face.mIndices[k + 1]});
      }
    }
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      out.vertices.emplace_back(static_cast<float>(options.scale * p.x),
                                static_cast<float>(options.scale * p.y),
                                static_cast<float>(options.scale * p.z));
    }
  }
  if (out.triangles.empty()) fail(what, "no triangles in the file");
  if (other_primitives > 0) {
    local.warnings.push_back(fmt::format("ignored {} point or line primitives", other_primitives));
  }

  // Validate and repair like any in-memory mesh.
  detail::validate_into(out, what, local, options);
  if (report != nullptr) *report = std::move(local);
  return out;
}

}  // namespace cariesim
