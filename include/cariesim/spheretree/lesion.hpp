#pragma once
/// Analytic lesion volumes placed on a tooth surface (docs/design.md §3), turned into level sets.

#include <string_view>
#include <vector>

#include "cariesim/common/hash.hpp"
#include "cariesim/spheretree/level_set.hpp"

namespace cariesim {

/// A lesion volume. The shape is laid out in the plane through `center` perpendicular to `normal`
/// (the outward surface normal there) and reaches `depth` mm below `center` along -normal; it also
/// extends above the surface so that CSG with the tooth cuts the surface cleanly.
struct LesionShape {
  enum class Kind : uint8_t { Disk, Stripe, Polygon, InvertedCone, Ellipsoid };
  Kind kind = Kind::Disk;
  Vec3 center = Vec3::Zero();    ///< mm, point on the tooth surface
  Vec3 normal = Vec3::UnitZ();   ///< outward surface normal at center (unit)
  Vec3 tangent = Vec3::UnitX();  ///< in-plane orientation of the shape (projected on the plane)
  double size = 2.0;             ///< mm: disk/cone diameter at the surface, stripe length, ellipsoid x axis
  double width = 0.6;            ///< mm: stripe width, ellipsoid y axis
  double depth = 1.5;            ///< mm below center along -normal
  /// Polygon: vertices (mm) in the (tangent, normal x tangent) plane, counter-clockwise.
  std::vector<Eigen::Vector2d> polygon;

  /// A square of side `side`, a triangle (equilateral) of side `side`, centred on the origin.
  static std::vector<Eigen::Vector2d> square(double side);
  static std::vector<Eigen::Vector2d> triangle(double side);

  /// Exact signed distance (mm, negative inside) of the analytic shape at p.
  [[nodiscard]] double distance(const Vec3& p) const;
  /// The level set of this shape, sampled on `voxel_mm` voxels around it.
  [[nodiscard]] LevelSet to_level_set(double voxel_mm, double half_band_mm) const;
};
/// A key hashes every field of LesionShape (common/hash.hpp: a new field must be counted here).
template <>
inline constexpr std::size_t kKeyFields<LesionShape> = 8;

std::string_view lesion_kind_name(LesionShape::Kind kind);
bool parse_lesion_kind(std::string_view name, LesionShape::Kind& out);

}  // namespace cariesim
