#pragma once
/// Helpers shared by the geometry tests: temporary files and small reference meshes written by hand.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "cariesim/geometry/mesh.hpp"

namespace cariesim::test {

/// A fresh directory under the test temp dir, named after the running test.
inline std::filesystem::path temp_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "cariesim_geometry" /
                              (std::string(info->test_suite_name()) + "_" + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// Writes `bytes` to `path` and returns the path.
inline std::filesystem::path write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

/// Reads a whole file.
inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The unit cube [0,1]^3: 8 vertices, 12 triangles wound outward.
inline TriangleMesh unit_cube() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

/// A latitude-longitude sphere (poles on z), wound outward (inward when `inward`), symmetric in x
/// (`segments` a multiple of 4), its coordinates snapped to multiples of 2^-12 mm so that moving it by
/// a whole number of millimetres is exact: two such spheres side by side on x are mirror images of
/// each other, and every point where their surfaces cross lies on an edge of each.
inline TriangleMesh uv_sphere(const Vec3& center, double radius, int segments = 24, int rings = 12,
                              bool inward = false) {
  const auto snap = [](double x) { return static_cast<float>(std::round(x * 4096.0) / 4096.0); };
  TriangleMesh m;
  m.vertices.emplace_back(snap(center.x()), snap(center.y()), snap(center.z() + radius));
  for (int i = 1; i < rings; ++i) {
    const double theta = std::numbers::pi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * std::numbers::pi * j / segments;
      // x from |cos| with its sign, so that x is exactly symmetric about the centre.
      const double c = std::cos(phi);
      const double x = std::copysign(std::round(std::abs(radius * std::sin(theta) * c) * 4096.0) / 4096.0, c);
      m.vertices.emplace_back(snap(center.x() + x),
                              snap(center.y() + radius * std::sin(theta) * std::sin(phi)),
                              snap(center.z() + radius * std::cos(theta)));
    }
  }
  m.vertices.emplace_back(snap(center.x()), snap(center.y()), snap(center.z() - radius));
  const auto ring = [&](int i, int j) {
    return static_cast<uint32_t>(1 + (i - 1) * segments + (j % segments));
  };
  const auto south = static_cast<uint32_t>(m.vertices.size() - 1);
  for (int j = 0; j < segments; ++j) {
    m.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      // Diagonals alternate from quad to quad, so that the triangles too are symmetric in x.
      if (j % 2 == 0) {
        m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
        m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
      } else {
        m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i, j + 1)});
        m.triangles.push_back({ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)});
      }
    }
    m.triangles.push_back({south, ring(rings - 1, j + 1), ring(rings - 1, j)});
  }
  if (inward)
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
  return m;
}

/// One mesh of two: the vertices and triangles of `b` after those of `a`.
inline TriangleMesh merged(TriangleMesh a, const TriangleMesh& b) {
  const auto offset = static_cast<uint32_t>(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (const auto& t : b.triangles) a.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return a;
}

/// ASCII STL text of a mesh.
inline std::string ascii_stl(const TriangleMesh& m) {
  std::string s = "solid test\n";
  for (const auto& t : m.triangles) {
    s += " facet normal 0 0 0\n  outer loop\n";
    for (const auto v : t) {
      const auto& p = m.vertices[v];
      s += "   vertex " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) +
           "\n";
    }
    s += "  endloop\n endfacet\n";
  }
  return s + "endsolid test\n";
}

/// OBJ text of a mesh (1-based indices).
inline std::string obj_text(const TriangleMesh& m) {
  std::string s = "# test mesh\n";
  for (const auto& p : m.vertices) {
    s += "v " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\n";
  }
  for (const auto& t : m.triangles) {
    s += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " + std::to_string(t[2] + 1) +
         "\n";
  }
  return s;
}

/// ASCII PLY text of a mesh.
inline std::string ply_text(const TriangleMesh& m) {
  std::string s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(m.vertices.size()) +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                  std::to_string(m.triangles.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& p : m.vertices) {
    s += std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\n";
  }
  for (const auto& t : m.triangles) {
    s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  }
  return s;
}

/// A binary little-endian PLY of a mesh (coordinates exactly as stored).
inline std::string binary_ply(const TriangleMesh& m) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(m.vertices.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
      std::to_string(m.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& p : m.vertices) s.append(reinterpret_cast<const char*>(p.data()), 3 * sizeof(float));
  for (const auto& t : m.triangles) {
    s.push_back('\3');
    for (const auto v : t) {
      const auto i = static_cast<int32_t>(v);
      s.append(reinterpret_cast<const char*>(&i), sizeof(i));
    }
  }
  return s;
}

}  // namespace cariesim::test
