#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <vector>

#include "geometry/mesh_checks.hpp"

namespace cariesim {

namespace {

using Corners = std::array<Vec3, 3>;

// Six times the signed volume of tetrahedron (a, b, c, d).
double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).cross(c - a).dot(d - a);
}

// Sign of x with |x| <= tol counted as zero.
int sign(double x, double tol) { return x > tol ? 1 : (x < -tol ? -1 : 0); }

// True when segment pq passes through the interior of triangle t; touching does not count.
bool segment_crosses(const Vec3& p, const Vec3& q, const Corners& t, double tol) {
  const int sp = sign(orient(t[0], t[1], t[2], p), tol);
  const int sq = sign(orient(t[0], t[1], t[2], q), tol);
  if (sp == 0 || sq == 0 || sp == sq) return false;
  const int s1 = sign(orient(p, q, t[0], t[1]), tol);
  const int s2 = sign(orient(p, q, t[1], t[2]), tol);
  const int s3 = sign(orient(p, q, t[2], t[0]), tol);
  return s1 != 0 && s1 == s2 && s2 == s3;
}

Corners corners(const TriangleMesh& mesh, const std::array<uint32_t, 3>& t) {
  return {mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(),
          mesh.vertices[t[2]].cast<double>()};
}

double longest_edge(const Corners& t) {
  return std::max({(t[1] - t[0]).norm(), (t[2] - t[1]).norm(), (t[0] - t[2]).norm()});
}

// Whether two triangles cross, given how many vertices they share (0 or 1).
bool triangles_cross(const TriangleMesh& mesh, const std::array<uint32_t, 3>& ti,
                     const std::array<uint32_t, 3>& tj) {
  const Corners a = corners(mesh, ti);
  const Corners b = corners(mesh, tj);
  const double scale = std::max(longest_edge(a), longest_edge(b));
  const double tol = 1e-9 * scale * scale * scale;

  // Shared vertex: the planes meet in a line through it, so any crossing ends on an opposite edge.
  for (int p = 0; p < 3; ++p) {
    for (int q = 0; q < 3; ++q) {
      if (ti[p] != tj[q]) continue;
      return segment_crosses(a[(p + 1) % 3], a[(p + 2) % 3], b, tol) ||
             segment_crosses(b[(q + 1) % 3], b[(q + 2) % 3], a, tol);
    }
  }
  // Disjoint index sets: the intersection segment ends where an edge of one crosses the other.
  for (int k = 0; k < 3; ++k) {
    if (segment_crosses(a[k], a[(k + 1) % 3], b, tol)) return true;
    if (segment_crosses(b[k], b[(k + 1) % 3], a, tol)) return true;
  }
  return false;
}

int shared_vertices(const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b) {
  int n = 0;
  for (const uint32_t u : a) n += static_cast<int>(u == b[0] || u == b[1] || u == b[2]);
  return n;
}

}  // namespace

std::size_t count_self_intersections(const TriangleMesh& mesh) {
  const std::size_t n = mesh.triangles.size();
  if (n < 2) return 0;

  // Triangle bounds and a grid whose cells are about two mean edges wide (at most 256 per axis).
  std::vector<Eigen::AlignedBox3d> boxes(n);
  double edge_sum = 0.0;
  for (std::size_t t = 0; t < n; ++t) {
    const Corners c = corners(mesh, mesh.triangles[t]);
    boxes[t].setEmpty();
    for (const auto& p : c) boxes[t].extend(p);
    edge_sum += longest_edge(c);
  }
  const Eigen::AlignedBox3d all = mesh.bounds();
  const Vec3 size = all.sizes();
  const double cell = std::max(2.0 * edge_sum / static_cast<double>(n), size.maxCoeff() / 256.0);
  if (!(cell > 0.0) || !std::isfinite(cell)) return 0;
  std::array<int64_t, 3> dims{};
  for (int k = 0; k < 3; ++k) dims[k] = std::clamp<int64_t>(static_cast<int64_t>(size[k] / cell) + 1, 1, 256);
  auto cell_of = [&](const Vec3& p, int k) {
    return std::clamp<int64_t>(static_cast<int64_t>((p[k] - all.min()[k]) / cell), 0, dims[k] - 1);
  };
  auto cell_range = [&](std::size_t t) {
    std::array<int64_t, 6> r{};
    for (int k = 0; k < 3; ++k) {
      r[k] = cell_of(boxes[t].min(), k);
      r[k + 3] = cell_of(boxes[t].max(), k);
    }
    return r;
  };
  auto cell_id = [&](int64_t x, int64_t y, int64_t z) {
    return static_cast<std::size_t>((z * dims[1] + y) * dims[0] + x);
  };
  const auto n_cells = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);

  // Cell -> triangles, compressed rows.
  std::vector<uint32_t> start(n_cells + 1, 0);
  for (std::size_t t = 0; t < n; ++t) {
    const auto r = cell_range(t);
    for (int64_t z = r[2]; z <= r[5]; ++z)
      for (int64_t y = r[1]; y <= r[4]; ++y)
        for (int64_t x = r[0]; x <= r[3]; ++x) ++start[cell_id(x, y, z) + 1];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  std::vector<uint32_t> members(start.back());
  for (std::size_t t = 0; t < n; ++t) {
    const auto r = cell_range(t);
    for (int64_t z = r[2]; z <= r[5]; ++z)
      for (int64_t y = r[1]; y <= r[4]; ++y)
        for (int64_t x = r[0]; x <= r[3]; ++x) members[fill[cell_id(x, y, z)]++] = static_cast<uint32_t>(t);
  }

  // Each pair once (j > i, stamped), bounds first, then the exact test.
  std::vector<uint32_t> stamp(n, ~uint32_t{0});
  std::size_t crossings = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = cell_range(i);
    for (int64_t z = r[2]; z <= r[5]; ++z)
      for (int64_t y = r[1]; y <= r[4]; ++y)
        for (int64_t x = r[0]; x <= r[3]; ++x) {
          const std::size_t c = cell_id(x, y, z);
          for (uint32_t m = start[c]; m < start[c + 1]; ++m) {
            const uint32_t j = members[m];
            if (j <= i || stamp[j] == i) continue;
            stamp[j] = static_cast<uint32_t>(i);
            if (!boxes[i].intersects(boxes[j])) continue;
            if (shared_vertices(mesh.triangles[i], mesh.triangles[j]) >= 2) continue;
            if (triangles_cross(mesh, mesh.triangles[i], mesh.triangles[j])) ++crossings;
          }
        }
  }
  return crossings;
}

}  // namespace cariesim
