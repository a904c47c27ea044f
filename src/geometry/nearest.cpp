// Nearest points on a triangle mesh through a uniform grid of its triangles (each listed in every
// cell its bounding box touches), with Phong's interpolated normal (nearest.hpp).
#include "cariesim/geometry/nearest.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cariesim/common/error.hpp"

namespace cariesim {

std::vector<Vec3> vertex_normals(std::span<const Vec3f> vertices,
                                 std::span<const std::array<uint32_t, 3>> triangles) {
  std::vector<Vec3> out(vertices.size(), Vec3::Zero());
  for (const auto& tri : triangles) {
    if (tri[0] >= vertices.size() || tri[1] >= vertices.size() || tri[2] >= vertices.size()) continue;
    const Vec3 a = vertices[tri[0]].cast<double>(), b = vertices[tri[1]].cast<double>(),
               c = vertices[tri[2]].cast<double>();
    const Vec3 area_normal = (b - a).cross(c - a);  // twice the area, outward for an outward winding
    for (const uint32_t v : tri) out[v] += area_normal;
  }
  for (Vec3& n : out)
    if (n.norm() > 0) n.normalize();
  return out;
}

std::vector<Vec3> vertex_normals(const TriangleMesh& mesh) {
  return vertex_normals(mesh.vertices, mesh.triangles);
}

Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double* u, double* v) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return *u = 0, *v = 0, a;
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return *u = 1, *v = 0, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double w = d1 / (d1 - d3);
    return *u = w, *v = 0, Vec3(a + w * ab);
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return *u = 0, *v = 1, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return *u = 0, *v = w, Vec3(a + w * ac);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return *u = 1 - w, *v = w, Vec3(b + w * (c - b));
  }
  const double denom = 1.0 / (va + vb + vc);
  *u = vb * denom;
  *v = vc * denom;
  return a + ab * *u + ac * *v;
}

MeshNearest::MeshNearest(const TriangleMesh& mesh, double cell)
    : vertices_(mesh.vertices), triangles_(mesh.triangles), cell_(cell) {
  if (!(cell > 0.0) || !std::isfinite(cell)) throw Error("mesh nearest: the cell size must be > 0 mm");
  for (const Vec3& n : vertex_normals(mesh)) normals_.push_back(n.cast<float>());
  const Eigen::AlignedBox3d box = mesh.bounds();
  origin_ = box.min();
  for (int k = 0; k < 3; ++k) {
    const double cells = std::floor((box.max()[k] - box.min()[k]) / cell) + 1.0;
    if (!(cells < double(1 << 20))) throw Error("mesh nearest: the mesh is too large for its cell size");
    dims_[k] = std::max<int64_t>(1, static_cast<int64_t>(cells));
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    Eigen::AlignedBox3d b;
    for (const uint32_t v : mesh.triangles[t]) b.extend(mesh.vertices[v].cast<double>());
    const auto lo = cell_of(b.min()), hi = cell_of(b.max());
    for (int64_t x = lo[0]; x <= hi[0]; ++x)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t z = lo[2]; z <= hi[2]; ++z) cells_.emplace_back(key(x, y, z), static_cast<uint32_t>(t));
  }
  std::sort(cells_.begin(), cells_.end());
}

std::array<int64_t, 3> MeshNearest::cell_of(const Vec3& p) const {
  std::array<int64_t, 3> c{};
  for (int k = 0; k < 3; ++k)
    c[k] =
        std::clamp<int64_t>(static_cast<int64_t>(std::floor((p[k] - origin_[k]) / cell_)), 0, dims_[k] - 1);
  return c;
}

uint64_t MeshNearest::key(int64_t x, int64_t y, int64_t z) const {
  return (static_cast<uint64_t>(z) << 40) | (static_cast<uint64_t>(y) << 20) | static_cast<uint64_t>(x);
}

bool MeshNearest::nearest(const Vec3& p, double reach, Hit* hit) const {
  if (!p.allFinite() || !(reach >= 0.0) || triangles_.empty()) return false;
  // Cells outside the box hold nothing: a point further than `reach` from the box finds nothing.
  const Eigen::AlignedBox3d box(origin_,
                                origin_ + cell_ * Vec3(double(dims_[0]), double(dims_[1]), double(dims_[2])));
  if (box.exteriorDistance(p) > reach) return false;
  const auto lo = cell_of(p - Vec3::Constant(reach)), hi = cell_of(p + Vec3::Constant(reach));
  double best = reach * reach;
  bool found = false;
  for (int64_t x = lo[0]; x <= hi[0]; ++x)
    for (int64_t y = lo[1]; y <= hi[1]; ++y)
      for (int64_t z = lo[2]; z <= hi[2]; ++z) {
        // A cell further than the best so far holds nothing nearer.
        const Vec3 corner = origin_ + cell_ * Vec3(double(x), double(y), double(z));
        if (Eigen::AlignedBox3d(corner, corner + Vec3::Constant(cell_)).squaredExteriorDistance(p) > best)
          continue;
        const uint64_t k = key(x, y, z);
        auto e = std::lower_bound(cells_.begin(), cells_.end(), std::pair<uint64_t, uint32_t>(k, 0));
        for (; e != cells_.end() && e->first == k; ++e) {
          const auto& tri = triangles_[e->second];
          double u = 0.0, v = 0.0;
          const Vec3 q =
              closest_on_triangle(p, vertices_[tri[0]].cast<double>(), vertices_[tri[1]].cast<double>(),
                                  vertices_[tri[2]].cast<double>(), &u, &v);
          const double d = (q - p).squaredNorm();
          if (d > best) continue;
          const Vec3 n = (1.0 - u - v) * normals_[tri[0]].cast<double>() +
                         u * normals_[tri[1]].cast<double>() + v * normals_[tri[2]].cast<double>();
          if (n.norm() <= 1e-12) continue;
          best = d;
          found = true;
          hit->point = q;
          hit->normal = n.normalized();
          hit->distance = std::sqrt(d);
        }
      }
  return found;
}

}  // namespace cariesim
