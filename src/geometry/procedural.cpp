// Procedural cuboid, gingiva band and tongue (the teeth are in tooth.cpp, the explorer in explorer.cpp).

#include "cariesim/geometry/procedural.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "cariesim/common/error.hpp"
#include "geometry/implicit_mesher.hpp"
#include "geometry/sdf.hpp"

namespace cariesim {

namespace {

using sdf::rounded_rect;
using sdf::smoothstep;
using sdf::sq;

// Most divisions along one edge of the cuboid: a few triangles per face, enough for display.
constexpr int kCuboidDivisions = 4;

void require(bool ok, const char* who, const std::string& problem) {
  if (!ok) throw Error(fmt::format("{}: {}", who, problem));
}

void require_range(const char* who, const char* name, double value, double lo, double hi) {
  require(std::isfinite(value) && value >= lo && value <= hi, who,
          fmt::format("{} = {} is outside [{}, {}]", name, value, lo, hi));
}

}  // namespace

TriangleMesh make_cuboid(const Vec3& size_mm) {
  for (int k = 0; k < 3; ++k) require_range("make_cuboid", "size", size_mm[k], 1e-3, 1e4);

  // Divisions per axis, in proportion to the edge lengths.
  std::array<int, 3> n{};
  for (int k = 0; k < 3; ++k) {
    n[k] = std::clamp(static_cast<int>(std::ceil(kCuboidDivisions * size_mm[k] / size_mm.maxCoeff() - 1e-9)),
                      1, kCuboidDivisions);
  }
  const Vec3 lo(-0.5 * size_mm.x(), -0.5 * size_mm.y(), -size_mm.z());

  // Lattice points on the surface, shared between faces.
  TriangleMesh mesh;
  std::unordered_map<int, uint32_t> index;
  auto vertex = [&](std::array<int, 3> ijk) {
    const int key = (ijk[0] * (kCuboidDivisions + 1) + ijk[1]) * (kCuboidDivisions + 1) + ijk[2];
    const auto [it, inserted] = index.try_emplace(key, static_cast<uint32_t>(mesh.vertices.size()));
    if (inserted) {
      Vec3 p;
      for (int k = 0; k < 3; ++k)
        p[k] = ijk[k] == n[k] ? lo[k] + size_mm[k] : lo[k] + size_mm[k] * ijk[k] / n[k];
      mesh.vertices.push_back(p.cast<float>());
    }
    return it->second;
  };

  // Each face is a grid over its two other axes (u, v cyclic after the normal axis a, so that
  // e_u x e_v = e_a), wound counter-clockwise seen from outside.
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3;
    const int v = (a + 2) % 3;
    for (const int side : {0, n[a]}) {
      for (int i = 0; i < n[u]; ++i) {
        for (int j = 0; j < n[v]; ++j) {
          std::array<std::array<int, 3>, 4> corner{};
          const std::array<std::pair<int, int>, 4> uv{{{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}}};
          for (int c = 0; c < 4; ++c) {
            corner[c][a] = side;
            corner[c][u] = uv[c].first;
            corner[c][v] = uv[c].second;
          }
          std::array<uint32_t, 4> q{vertex(corner[0]), vertex(corner[1]), vertex(corner[2]),
                                    vertex(corner[3])};
          if (side == 0) std::swap(q[1], q[3]);
          mesh.triangles.push_back({q[0], q[1], q[2]});
          mesh.triangles.push_back({q[0], q[2], q[3]});
        }
      }
    }
  }
  return mesh;
}

TriangleMesh make_gingiva_band(const GingivaParams& params) {
  const char* who = "make_gingiva_band";
  require(!params.path.empty(), who, "the path has no points");
  for (std::size_t i = 0; i < params.path.size(); ++i) {
    require(params.path[i].allFinite() && params.path[i].cwiseAbs().maxCoeff() < 1e4, who,
            fmt::format("path point {} is not finite or too far out", i));
  }
  require_range(who, "width (mm)", params.width, 0.5, 200.0);
  require_range(who, "height (mm)", params.height, 0.5, 100.0);
  require_range(who, "resolution (mm)", params.resolution, 0.05, 5.0);

  // The band: at each point, the distance (in xy) to the path and the margin height there define a
  // rounded rectangle cross-section, width x height, hanging below the margin; the ends are round.
  const std::vector<Vec3> path = params.path;
  const double half_width = 0.5 * params.width;
  const double half_height = 0.5 * params.height;
  const double round = 0.9 * std::min(half_width, half_height);
  auto band = [path, half_width, half_height, round](const Vec3& p) {
    double best = std::numeric_limits<double>::infinity();
    double margin = path.front().z();
    for (std::size_t i = 0; i < path.size(); ++i) {
      const Vec3& a = path[i];
      const Vec3& b = i + 1 < path.size() ? path[i + 1] : path[i];
      const double ex = b.x() - a.x();
      const double ey = b.y() - a.y();
      const double len2 = ex * ex + ey * ey;
      const double t =
          len2 > 0.0 ? std::clamp(((p.x() - a.x()) * ex + (p.y() - a.y()) * ey) / len2, 0.0, 1.0) : 0.0;
      const double d2 = sq(p.x() - (a.x() + t * ex)) + sq(p.y() - (a.y() + t * ey));
      if (d2 < best) {
        best = d2;
        margin = a.z() + t * (b.z() - a.z());
      }
    }
    return rounded_rect(std::sqrt(best), p.z() - (margin - half_height), half_width, half_height, round);
  };

  Eigen::AlignedBox3d box;
  for (const auto& q : path) box.extend(q);
  const double pad = half_width + 3.0 * params.resolution + 0.5;
  box.min() -= Vec3(pad, pad, params.height + 3.0 * params.resolution + 0.5);
  box.max() += Vec3(pad, pad, 3.0 * params.resolution + 0.5);
  return mesh_implicit(band, box, params.resolution, 1.5, who);
}

TriangleMesh make_tongue(const TongueParams& params) {
  const char* who = "make_tongue";
  require_range(who, "length (mm)", params.length, 2.0, 300.0);
  require_range(who, "width (mm)", params.width, 2.0, 300.0);
  require_range(who, "height (mm)", params.height, 1.0, 300.0);
  require_range(who, "resolution (mm)", params.resolution, 0.05, 10.0);

  // A flattened superellipsoid (exponent 3 in plan, 2.5 in height) narrowing toward its tip at +x.
  const double a = 0.5 * params.length;
  const double b = 0.5 * params.width;
  const double c = 0.5 * params.height;
  constexpr double kTipNarrowing = 0.35;
  const double scale = std::min({a, (1.0 - kTipNarrowing) * b, c});
  auto tongue = [a, b, c, scale](const Vec3& p) {
    const double qx = std::abs(p.x()) / a;
    const double qy = std::abs(p.y()) / (b * (1.0 - kTipNarrowing * smoothstep(-0.2, 1.0, p.x() / a)));
    const double qz = std::abs(p.z()) / c;
    const double plan = std::pow(std::pow(qx, 3.0) + std::pow(qy, 3.0), 1.0 / 3.0);
    const double norm = std::pow(std::pow(plan, 2.5) + std::pow(qz, 2.5), 1.0 / 2.5);
    return (norm - 1.0) * scale;
  };
  const double pad = 3.0 * params.resolution + 0.5;
  const Eigen::AlignedBox3d box(Vec3(-a - pad, -b - pad, -c - pad), Vec3(a + pad, b + pad, c + pad));
  return mesh_implicit(tongue, box, params.resolution, 2.0, who);
}

}  // namespace cariesim
