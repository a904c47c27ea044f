#include "cariesim/spheretree/lesion.hpp"

#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "cariesim/common/error.hpp"
#include "spheretree/level_set_impl.hpp"

namespace cariesim {

namespace {

using Vec2 = Eigen::Vector2d;

constexpr std::array<std::string_view, 5> kKindNames{"disk", "stripe", "polygon", "inverted-cone",
                                                     "ellipsoid"};

// Signed distance from p to a closed polygon (exact; negative inside, either winding).
double polygon_distance(const std::vector<Vec2>& poly, const Vec2& p) {
  if (poly.size() < 3) return std::numeric_limits<double>::infinity();
  double d2 = std::numeric_limits<double>::infinity();
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 e = poly[j] - poly[i];
    const Vec2 w = p - poly[i];
    const double t = std::clamp(w.dot(e) / std::max(e.squaredNorm(), 1e-300), 0.0, 1.0);
    d2 = std::min(d2, (w - t * e).squaredNorm());
    // Even-odd crossing test along +x.
    const bool crosses = (poly[i].y() > p.y()) != (poly[j].y() > p.y());
    if (crosses && p.x() < poly[i].x() + (p.y() - poly[i].y()) * e.x() / e.y()) inside = !inside;
  }
  const double d = std::sqrt(d2);
  return inside ? -d : d;
}

// Exact signed distance of a 2-D shape extruded over z in [bottom, top], given its 2-D distance.
double extrude(double d2, double z, double bottom, double top) {
  const double dz = std::max(bottom - z, z - top);
  const double inside = std::min(std::max(d2, dz), 0.0);
  const Vec2 outside(std::max(d2, 0.0), std::max(dz, 0.0));
  return inside + outside.norm();
}

// Root of the ellipse/ellipsoid secular equation by bisection (Eberly, "Distance from a point to an
// ellipse, an ellipsoid, or a hyperellipsoid"): sum (r_i z_i / (s + r_i))^2 = 1.
template <int N>
double secular_root(const std::array<double, N>& r, const std::array<double, N>& z, double g) {
  std::array<double, N> n{};
  double len2 = 0.0;
  for (int i = 0; i < N; ++i) {
    n[i] = r[i] * z[i];
    len2 += n[i] * n[i];
  }
  double s0 = z[N - 1] - 1.0;
  double s1 = g < 0.0 ? 0.0 : std::sqrt(len2) - 1.0;
  double s = 0.0;
  for (int iter = 0; iter < 200; ++iter) {
    s = 0.5 * (s0 + s1);
    if (s == s0 || s == s1) break;
    double f = -1.0;
    for (int i = 0; i < N; ++i) {
      const double ratio = n[i] / (s + r[i]);
      f += ratio * ratio;
    }
    if (f > 0.0) {
      s0 = s;
    } else if (f < 0.0) {
      s1 = s;
    } else {
      break;
    }
  }
  return s;
}

// Closest point on an ellipse with semi-axes e0 >= e1 > 0 to (y0, y1) in the first quadrant.
Vec2 closest_on_ellipse(double e0, double e1, double y0, double y1) {
  if (y1 > 0.0) {
    if (y0 > 0.0) {
      const double z0 = y0 / e0, z1 = y1 / e1;
      const double g = z0 * z0 + z1 * z1 - 1.0;
      if (g == 0.0) return {y0, y1};
      const double r0 = (e0 / e1) * (e0 / e1);
      const double s = secular_root<2>({r0, 1.0}, {z0, z1}, g);
      return {r0 * y0 / (s + r0), y1 / (s + 1.0)};
    }
    return {0.0, e1};
  }
  const double numer = e0 * y0, denom = e0 * e0 - e1 * e1;
  if (numer < denom) {
    const double xde = numer / denom;
    return {e0 * xde, e1 * std::sqrt(std::max(0.0, 1.0 - xde * xde))};
  }
  return {e0, 0.0};
}

// Closest point on an ellipsoid with semi-axes e0 >= e1 >= e2 > 0 to y in the first octant.
Vec3 closest_on_ellipsoid(const Vec3& e, const Vec3& y) {
  if (y[2] > 0.0) {
    if (y[1] > 0.0) {
      if (y[0] > 0.0) {
        const Vec3 z = y.cwiseQuotient(e);
        const double g = z.squaredNorm() - 1.0;
        if (g == 0.0) return y;
        const double r0 = (e[0] / e[2]) * (e[0] / e[2]);
        const double r1 = (e[1] / e[2]) * (e[1] / e[2]);
        const double s = secular_root<3>({r0, r1, 1.0}, {z[0], z[1], z[2]}, g);
        return {r0 * y[0] / (s + r0), r1 * y[1] / (s + r1), y[2] / (s + 1.0)};
      }
      const Vec2 x = closest_on_ellipse(e[1], e[2], y[1], y[2]);
      return {0.0, x[0], x[1]};
    }
    if (y[0] > 0.0) {
      const Vec2 x = closest_on_ellipse(e[0], e[2], y[0], y[2]);
      return {x[0], 0.0, x[1]};
    }
    return {0.0, 0.0, e[2]};
  }
  const double denom0 = e[0] * e[0] - e[2] * e[2], denom1 = e[1] * e[1] - e[2] * e[2];
  const double numer0 = e[0] * y[0], numer1 = e[1] * y[1];
  if (numer0 < denom0 && numer1 < denom1) {
    const double xde0 = numer0 / denom0, xde1 = numer1 / denom1;
    const double discr = 1.0 - xde0 * xde0 - xde1 * xde1;
    if (discr > 0.0) return {e[0] * xde0, e[1] * xde1, e[2] * std::sqrt(discr)};
  }
  const Vec2 x = closest_on_ellipse(e[0], e[1], y[0], y[1]);
  return {x[0], x[1], 0.0};
}

// Exact signed distance to an axis-aligned ellipsoid with semi-axes `axes` centred on the origin.
double ellipsoid_distance(const Vec3& axes, const Vec3& p) {
  // Sort the axes in decreasing order and fold p into the first octant.
  std::array<int, 3> order{0, 1, 2};
  std::sort(order.begin(), order.end(), [&](int a, int b) { return axes[a] > axes[b]; });
  Vec3 e, y;
  for (int i = 0; i < 3; ++i) {
    e[i] = axes[order[i]];
    y[i] = std::abs(p[order[i]]);
  }
  const double d = (closest_on_ellipsoid(e, y) - y).norm();
  return y.cwiseQuotient(e).squaredNorm() < 1.0 ? -d : d;
}

// The lesion's local frame: columns x (tangent), y (normal x tangent), z (normal).
Mat3 local_frame(const LesionShape& s) {
  const Vec3 z = s.normal.normalized();
  Vec3 x = s.tangent - s.tangent.dot(z) * z;
  if (x.norm() < 1e-9) x = z.unitOrthogonal();
  x.normalize();
  Mat3 frame;
  frame.col(0) = x;
  frame.col(1) = z.cross(x);
  frame.col(2) = z;
  return frame;
}

// How far the shape reaches above the surface (its depth plus half its lateral extent), so that CSG
// with a curved tooth cuts cleanly.
double top_of(const LesionShape& s) {
  double lateral = 0.5 * s.size;
  if (s.kind == LesionShape::Kind::Polygon) {
    lateral = 0.0;
    for (const Vec2& v : s.polygon) lateral = std::max(lateral, v.norm());
  }
  return s.depth + lateral;
}

// Rejects shapes whose parameters cannot describe a volume.
void check_shape(const LesionShape& s) {
  const auto bad = [&](const std::string& field, double value) {
    throw Error("lesion (" + std::string(lesion_kind_name(s.kind)) + "): " + field +
                " must be a positive finite number of mm, got " + std::to_string(value));
  };
  if (!s.center.allFinite()) throw Error("lesion: center is not finite");
  if (!s.normal.allFinite() || s.normal.norm() < 1e-9)
    throw Error("lesion: normal must be a non-zero vector");
  if (!s.tangent.allFinite()) throw Error("lesion: tangent is not finite");
  if (!(s.depth > 0.0) || !std::isfinite(s.depth)) bad("depth", s.depth);
  if (s.kind != LesionShape::Kind::Polygon && (!(s.size > 0.0) || !std::isfinite(s.size)))
    bad("size", s.size);
  if ((s.kind == LesionShape::Kind::Stripe || s.kind == LesionShape::Kind::Ellipsoid) &&
      (!(s.width > 0.0) || !std::isfinite(s.width))) {
    bad("width", s.width);
  }
  if (s.kind == LesionShape::Kind::Polygon) {
    if (s.polygon.size() < 3) {
      throw Error("lesion (polygon): needs at least 3 vertices, got " + std::to_string(s.polygon.size()));
    }
    for (const Vec2& v : s.polygon) {
      if (!v.allFinite()) throw Error("lesion (polygon): a vertex is not finite");
    }
  }
}

// Local axis-aligned bounds of the shape (mm, lesion frame).
Eigen::AlignedBox3d local_bounds(const LesionShape& s) {
  const double top = top_of(s);
  switch (s.kind) {
    case LesionShape::Kind::Disk:
    case LesionShape::Kind::InvertedCone:
      return {Vec3(-0.5 * s.size, -0.5 * s.size, -s.depth), Vec3(0.5 * s.size, 0.5 * s.size, top)};
    case LesionShape::Kind::Stripe: {
      const double half_w = 0.5 * s.width;
      const double half_l = std::max(0.5 * s.size, half_w);
      return {Vec3(-half_l, -half_w, -s.depth), Vec3(half_l, half_w, top)};
    }
    case LesionShape::Kind::Polygon: {
      Eigen::AlignedBox2d box;
      for (const Vec2& v : s.polygon) box.extend(v);
      return {Vec3(box.min().x(), box.min().y(), -s.depth), Vec3(box.max().x(), box.max().y(), top)};
    }
    case LesionShape::Kind::Ellipsoid:
      return {Vec3(-0.5 * s.size, -0.5 * s.width, -s.depth), Vec3(0.5 * s.size, 0.5 * s.width, s.depth)};
  }
  return {};
}

}  // namespace

std::vector<Eigen::Vector2d> LesionShape::square(double side) {
  const double h = 0.5 * side;
  return {{-h, -h}, {h, -h}, {h, h}, {-h, h}};
}

std::vector<Eigen::Vector2d> LesionShape::triangle(double side) {
  // Equilateral, centroid on the origin, counter-clockwise.
  const double circumradius = side / std::sqrt(3.0);
  std::vector<Vec2> out;
  for (int i = 0; i < 3; ++i) {
    const double a = std::numbers::pi / 2.0 + 2.0 * std::numbers::pi * i / 3.0;
    out.emplace_back(circumradius * std::cos(a), circumradius * std::sin(a));
  }
  return out;
}

double LesionShape::distance(const Vec3& p) const {
  const Vec3 q = local_frame(*this).transpose() * (p - center);
  const double top = top_of(*this);
  switch (kind) {
    case Kind::Disk: {
      // Cylinder from `depth` below the surface to `top` above it, flat bottom.
      const double radial = Vec2(q.x(), q.y()).norm() - 0.5 * size;
      return extrude(radial, q.z(), -depth, top);
    }
    case Kind::Stripe: {
      // Stadium of length `size` and width `width` (rounded ends), extruded.
      const double half_w = 0.5 * width;
      const double half_seg = std::max(0.5 * size - half_w, 0.0);
      const double along = std::clamp(q.x(), -half_seg, half_seg);
      const double d2 = Vec2(q.x() - along, q.y()).norm() - half_w;
      return extrude(d2, q.z(), -depth, top);
    }
    case Kind::Polygon:
      return extrude(polygon_distance(polygon, Vec2(q.x(), q.y())), q.z(), -depth, top);
    case Kind::InvertedCone: {
      // Solid of revolution: the meridian polygon is a cone (apex at -depth, diameter `size` at the
      // surface) capped by a cylinder of the same diameter above the surface.
      const double r = 0.5 * size;
      const std::vector<Vec2> meridian{{-r, top}, {-r, 0.0}, {0.0, -depth}, {r, 0.0}, {r, top}};
      return polygon_distance(meridian, Vec2(Vec2(q.x(), q.y()).norm(), q.z()));
    }
    case Kind::Ellipsoid:
      return ellipsoid_distance(Vec3(0.5 * size, 0.5 * width, depth), q);
  }
  return std::numeric_limits<double>::infinity();
}

// Samples the analytic distance on voxels near the shape's boundary (8^3 blocks far from it are
// skipped), then flood-fills the sign so the interior reads -band.
LevelSet LesionShape::to_level_set(double voxel_mm, double half_band_mm) const {
  check_shape(*this);
  if (!(voxel_mm > 0.0) || !std::isfinite(voxel_mm)) {
    throw Error("lesion level set: voxel size must be positive, got " + std::to_string(voxel_mm));
  }
  if (!(half_band_mm >= voxel_mm) || !std::isfinite(half_band_mm)) {
    throw Error("lesion level set: half band must be at least one voxel, got " +
                std::to_string(half_band_mm));
  }
  ensure_openvdb_initialized();

  // World bounds of the shape, widened by the band, in index space.
  const Mat3 frame = local_frame(*this);
  const Eigen::AlignedBox3d local = local_bounds(*this);
  Eigen::AlignedBox3d world;
  for (int corner = 0; corner < 8; ++corner) {
    world.extend(center + frame * local.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner)));
  }
  const Vec3 pad = Vec3::Constant(half_band_mm + voxel_mm);
  const Eigen::Vector3i lo = ((world.min() - pad) / voxel_mm).array().floor().cast<int>();
  const Eigen::Vector3i hi = ((world.max() + pad) / voxel_mm).array().ceil().cast<int>();

  auto grid = openvdb::FloatGrid::create(static_cast<float>(half_band_mm));
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel_mm));
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  auto accessor = grid->getAccessor();

  constexpr int kBlock = 8;
  const double block_half_diagonal = 0.5 * std::sqrt(3.0) * kBlock * voxel_mm;
  for (int bx = lo.x(); bx <= hi.x(); bx += kBlock) {
    for (int by = lo.y(); by <= hi.y(); by += kBlock) {
      for (int bz = lo.z(); bz <= hi.z(); bz += kBlock) {
        const Vec3 block_center = (Vec3(bx, by, bz) + Vec3::Constant(0.5 * (kBlock - 1))) * voxel_mm;
        if (std::abs(distance(block_center)) > half_band_mm + block_half_diagonal) continue;
        for (int i = bx; i < bx + kBlock; ++i) {
          for (int j = by; j < by + kBlock; ++j) {
            for (int k = bz; k < bz + kBlock; ++k) {
              const double d = distance(Vec3(i, j, k) * voxel_mm);
              if (std::abs(d) < half_band_mm)
                accessor.setValue(openvdb::Coord(i, j, k), static_cast<float>(d));
            }
          }
        }
      }
    }
  }
  openvdb::tools::signedFloodFill(grid->tree());
  openvdb::tools::pruneLevelSet(grid->tree());

  LevelSet out;
  out.impl().grid = std::move(grid);
  return out;
}

std::string_view lesion_kind_name(LesionShape::Kind kind) {
  return kKindNames[static_cast<std::size_t>(kind)];
}

bool parse_lesion_kind(std::string_view name, LesionShape::Kind& out) {
  for (std::size_t i = 0; i < kKindNames.size(); ++i) {
    if (kKindNames[i] == name) {
      out = static_cast<LesionShape::Kind>(i);
      return true;
    }
  }
  // "circle" is accepted for the round lesion too (docs/scene-format.md).
  if (name == "circle") {
    out = LesionShape::Kind::Disk;
    return true;
  }
  return false;
}

}  // namespace cariesim
