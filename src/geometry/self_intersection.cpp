// Mesh checks of validate_mesh: triangles crossing each other, and closed shells inside others.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <numeric>
#include <vector>

#include "geometry/mesh_checks.hpp"

namespace cariesim {

namespace {

using Corners = std::array<Vec3, 3>;

// Exact orientation tests: the vertices on an integer grid of 2^-k mm (k as fine as keeps every
// coordinate below 2^40 units from the mesh's lowest corner: 2^-30 mm for a 1 m mesh, finer for a
// tooth, far below a float's resolution there), and determinants in 128-bit integers (below 2^123, so
// exact). A crossing that runs exactly along edges is then told from a sliver that only passes near
// one, which a tolerance cannot do.
__extension__ typedef __int128 Wide;
using Point = std::array<int64_t, 3>;
using Triangle3 = std::array<Point, 3>;

// Sign of det[b - a, c - a, d - a]: six times the signed volume of tetrahedron (a, b, c, d).
int orient(const Point& a, const Point& b, const Point& c, const Point& d) {
  const Wide bx = b[0] - a[0], by = b[1] - a[1], bz = b[2] - a[2];
  const Wide cx = c[0] - a[0], cy = c[1] - a[1], cz = c[2] - a[2];
  const Wide dx = d[0] - a[0], dy = d[1] - a[1], dz = d[2] - a[2];
  const Wide det = bx * (cy * dz - cz * dy) - by * (cx * dz - cz * dx) + bz * (cx * dy - cy * dx);
  return (det > 0) - (det < 0);
}

// True when segment pq passes from one side of triangle t's plane to the other through t, its edges
// or corners included: two sheets whose crossing runs exactly along edges (a mesh and its mirror
// image, as two equal spheres side by side) cross there too. An end on the plane does not count.
bool segment_crosses(const Point& p, const Point& q, const Triangle3& t) {
  const int sp = orient(t[0], t[1], t[2], p);
  const int sq = orient(t[0], t[1], t[2], q);
  if (sp == 0 || sq == 0 || sp == sq) return false;
  const int s1 = orient(p, q, t[0], t[1]);
  const int s2 = orient(p, q, t[1], t[2]);
  const int s3 = orient(p, q, t[2], t[0]);
  const bool none_negative = s1 >= 0 && s2 >= 0 && s3 >= 0;
  const bool none_positive = s1 <= 0 && s2 <= 0 && s3 <= 0;
  return (none_negative || none_positive) && (s1 != 0 || s2 != 0 || s3 != 0);
}

// The mesh's vertices on the exact grid.
std::vector<Point> grid_points(const TriangleMesh& mesh) {
  const Eigen::AlignedBox3d box = mesh.bounds();
  const double extent = std::max(box.sizes().maxCoeff(), 1e-30);
  const double unit = std::ldexp(1.0, 40 - static_cast<int>(std::ceil(std::log2(extent))));
  std::vector<Point> out(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    for (int k = 0; k < 3; ++k)
      out[v][k] = static_cast<int64_t>(std::llround((mesh.vertices[v][k] - box.min()[k]) * unit));
  return out;
}

Corners corners(const TriangleMesh& mesh, const std::array<uint32_t, 3>& t) {
  return {mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(),
          mesh.vertices[t[2]].cast<double>()};
}

double longest_edge(const Corners& t) {
  return std::max({(t[1] - t[0]).norm(), (t[2] - t[1]).norm(), (t[0] - t[2]).norm()});
}

// Whether two triangles cross, given how many vertices they share (0 or 1).
bool triangles_cross(const std::vector<Point>& points, const std::array<uint32_t, 3>& ti,
                     const std::array<uint32_t, 3>& tj) {
  const Triangle3 a = {points[ti[0]], points[ti[1]], points[ti[2]]};
  const Triangle3 b = {points[tj[0]], points[tj[1]], points[tj[2]]};

  // Shared vertex: the planes meet in a line through it, so any crossing ends on an opposite edge
  // (which cannot pass through the shared vertex itself: the triangle would be degenerate).
  for (int p = 0; p < 3; ++p) {
    for (int q = 0; q < 3; ++q) {
      if (ti[p] != tj[q]) continue;
      return segment_crosses(a[(p + 1) % 3], a[(p + 2) % 3], b) ||
             segment_crosses(b[(q + 1) % 3], b[(q + 2) % 3], a);
    }
  }
  // Disjoint index sets: the intersection segment ends where an edge of one crosses the other.
  for (int k = 0; k < 3; ++k) {
    if (segment_crosses(a[k], a[(k + 1) % 3], b)) return true;
    if (segment_crosses(b[k], b[(k + 1) % 3], a)) return true;
  }
  return false;
}

int shared_vertices(const std::array<uint32_t, 3>& a, const std::array<uint32_t, 3>& b) {
  int n = 0;
  for (const uint32_t u : a) n += static_cast<int>(u == b[0] || u == b[1] || u == b[2]);
  return n;
}

// Solid angle (sr) of triangle abc seen from p (Van Oosterom and Strackee, 1983), signed by winding.
double solid_angle(const Vec3& p, const Corners& t) {
  const Vec3 a = t[0] - p;
  const Vec3 b = t[1] - p;
  const Vec3 c = t[2] - p;
  const double la = a.norm();
  const double lb = b.norm();
  const double lc = c.norm();
  const double numerator = a.dot(b.cross(c));
  const double denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
  return 2.0 * std::atan2(numerator, denominator);
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
  const std::vector<Point> points = grid_points(mesh);
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
            if (triangles_cross(points, mesh.triangles[i], mesh.triangles[j])) ++crossings;
          }
        }
  }
  return crossings;
}

NestedShells find_nested_shell(const TriangleMesh& mesh, const std::vector<uint32_t>& component,
                               std::size_t components, std::size_t max_work) {
  NestedShells out;
  if (components < 2) return out;

  // Each shell's bounds, triangles and a few of its vertices to test (first, middle, last).
  std::vector<Eigen::AlignedBox3d> bounds(components);
  std::vector<std::vector<uint32_t>> triangles(components);
  for (auto& b : bounds) b.setEmpty();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const uint32_t c = component[t];
    triangles[c].push_back(static_cast<uint32_t>(t));
    for (const uint32_t v : mesh.triangles[t]) bounds[c].extend(mesh.vertices[v].cast<double>());
  }

  // A shell lies inside another only within its bounds; there, the winding number of the other shell
  // (closed, and crossing nothing: checked before) at the shell's vertices is +-1 inside, 0 outside.
  std::size_t work = 0;
  for (std::size_t inner = 0; inner < components; ++inner) {
    const std::vector<uint32_t>& own = triangles[inner];
    if (own.empty()) continue;
    const std::array<uint32_t, 3> probes = {mesh.triangles[own.front()][0],
                                            mesh.triangles[own[own.size() / 2]][1],
                                            mesh.triangles[own.back()][2]};
    for (std::size_t outer = 0; outer < components; ++outer) {
      if (outer == inner || triangles[outer].empty() || !bounds[outer].contains(bounds[inner])) continue;
      work += probes.size() * triangles[outer].size();
      if (work > max_work) {
        out.too_costly = true;
        return out;
      }
      int inside = 0;
      for (const uint32_t v : probes) {
        const Vec3 p = mesh.vertices[v].cast<double>();
        double total = 0.0;
        for (const uint32_t t : triangles[outer]) total += solid_angle(p, corners(mesh, mesh.triangles[t]));
        inside += std::abs(total) > 2.0 * std::numbers::pi;  // winding number above 1/2
      }
      if (inside >= 2) {
        out.found = true;
        out.inner = static_cast<uint32_t>(inner);
        out.outer = static_cast<uint32_t>(outer);
        out.inner_triangles = own.size();
        out.outer_triangles = triangles[outer].size();
        return out;
      }
    }
  }
  return out;
}

}  // namespace cariesim
