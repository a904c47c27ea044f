#pragma once
/// Helpers shared by the geometry tests: temporary files and small reference meshes written by hand.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
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

}  // namespace cariesim::test
