#pragma once
// Closed meshes built inside the spheretree tests (an icosphere and a box), and the real scans.

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <utility>

#include "cariesim/geometry/mesh.hpp"

namespace cariesim::testing {

/// An icosphere of `radius` (mm) about `center`, `subdivisions` times refined, wound outward.
inline TriangleMesh make_icosphere(double radius, int subdivisions, const Vec3& center = Vec3::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v{{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                      {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<std::array<uint32_t, 3>> f{{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                         {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                         {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                         {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    const auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      const auto index = static_cast<uint32_t>(v.size() - 1);
      mid.emplace(key, index);
      return index;
    };
    std::vector<std::array<uint32_t, 3>> next;
    for (const auto& tri : f) {
      const uint32_t ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]),
                     ca = midpoint(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    f = std::move(next);
  }
  TriangleMesh mesh;
  for (const auto& p : v) mesh.vertices.push_back((center + radius * p).cast<float>());
  mesh.triangles = std::move(f);
  return mesh;
}

/// An axis-aligned box from `lo` to `hi` (mm), wound outward.
inline TriangleMesh make_box(const Vec3& lo, const Vec3& hi) {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.emplace_back(static_cast<float>((i & 1) ? hi.x() : lo.x()),
                               static_cast<float>((i & 2) ? hi.y() : lo.y()),
                               static_cast<float>((i & 4) ? hi.z() : lo.z()));
  }
  mesh.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                    {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return mesh;
}

/// A real tooth scan shipped in data/open-full-jaw (empty path when the file is missing).
inline std::filesystem::path scan_path(const std::string& tooth) {
  const std::filesystem::path p =
      std::filesystem::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26" / (tooth + ".ply");
  return std::filesystem::exists(p) ? p : std::filesystem::path();
}

}  // namespace cariesim::testing
