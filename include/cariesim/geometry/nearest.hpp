#pragma once
/// The point of a triangle mesh nearest a query point, and the mesh's normal there interpolated from
/// its vertex normals (Phong's normal), for force shading (docs/step.md, "Force shading") and the
/// experiments that measure against a scan's smooth surface.

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

/// Unit vertex normals: each vertex's adjacent triangles' normals weighted by their areas (zero for a
/// vertex no triangle uses; a triangle with an index out of range is skipped).
std::vector<Vec3> vertex_normals(std::span<const Vec3f> vertices,
                                 std::span<const std::array<uint32_t, 3>> triangles);
std::vector<Vec3> vertex_normals(const TriangleMesh& mesh);

/// Ericson, Real-Time Collision Detection §5.1.5: the point of triangle abc nearest p, with the
/// barycentric weights of b (*u) and c (*v).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double* u, double* v);

/// Nearest-point queries on one mesh (a copy of its vertices, triangles and vertex normals), through
/// a uniform grid of its triangles. A query allocates nothing. Default-constructed: no mesh, no hit.
class MeshNearest {
 public:
  MeshNearest() = default;
  /// `cell`: the grid's cell size (mm, > 0).
  MeshNearest(const TriangleMesh& mesh, double cell);
  [[nodiscard]] bool empty() const { return triangles_.empty(); }

  struct Hit {
    Vec3 point = Vec3::Zero();   ///< mm, on the mesh
    Vec3 normal = Vec3::Zero();  ///< unit: the vertex normals interpolated at `point`
    double distance = 0.0;       ///< mm
  };
  /// The nearest point within `reach` mm of p; false when the mesh has none that close.
  bool nearest(const Vec3& p, double reach, Hit* hit) const;

 private:
  [[nodiscard]] std::array<int64_t, 3> cell_of(const Vec3& p) const;
  [[nodiscard]] uint64_t key(int64_t x, int64_t y, int64_t z) const;

  std::vector<Vec3f> vertices_;                     // mm
  std::vector<std::array<uint32_t, 3>> triangles_;  // indices into vertices_
  std::vector<Vec3f> normals_;                      // unit, by vertex
  double cell_ = 1.0;                               // mm
  Vec3 origin_ = Vec3::Zero();                      // mm
  std::array<int64_t, 3> dims_{};
  /// (cell key, triangle) for every cell a triangle's bounding box touches, sorted: only occupied
  /// cells take memory, however large the mesh's box
  std::vector<std::pair<uint64_t, uint32_t>> cells_;
};

}  // namespace cariesim
