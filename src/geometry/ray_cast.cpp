#include "cariesim/geometry/ray_cast.hpp"

#include <cmath>

#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {

// A determinant below this means the line runs in the triangle's plane: no single crossing.
constexpr double kParallelDet = 1e-14;

}  // namespace

std::optional<double> nearest_crossing(const TriangleMesh& mesh, const Vec3& origin, const Vec3& direction,
                                       double range) {
  if (!origin.allFinite()) throw Error("nearest_crossing: the line's origin is not finite");
  if (!direction.allFinite() || direction.isZero(0.0)) {
    throw Error("nearest_crossing: the line's direction is not a finite non-zero vector");
  }
  if (!(range >= 0.0)) throw Error("nearest_crossing: the range must be a number >= 0");
  std::optional<double> best;
  for (const auto& tri : mesh.triangles) {
    // Möller-Trumbore, double precision, both windings.
    const Vec3 a = mesh.vertices[tri[0]].cast<double>();
    const Vec3 e1 = mesh.vertices[tri[1]].cast<double>() - a;
    const Vec3 e2 = mesh.vertices[tri[2]].cast<double>() - a;
    const Vec3 p = direction.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < kParallelDet) continue;
    const Vec3 s = origin - a;
    const double u = s.dot(p) / det;
    if (u < 0.0 || u > 1.0) continue;
    const Vec3 q = s.cross(e1);
    const double v = direction.dot(q) / det;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = e2.dot(q) / det;
    if (std::abs(t) <= range && (!best || std::abs(t) < std::abs(*best))) best = t;
  }
  return best;
}

}  // namespace cariesim
