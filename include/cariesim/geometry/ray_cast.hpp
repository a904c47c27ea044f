#pragma once
/// Where a line meets a triangle mesh (the lesion placement's snap onto its tooth, docs/scene-format.md).

#include <optional>

#include "cariesim/common/math.hpp"
#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

/// The crossing of the line `origin` + t `direction` with `mesh` nearest `origin`: the t closest to 0
/// with |t| <= `range`, on either side of `origin` and through triangles of either winding (Möller and
/// Trumbore's ray-triangle test in double precision). t is in units of `direction` (mm for a unit
/// direction). None when the line meets no triangle within the range, or only in a triangle's plane.
/// Throws cariesim::Error for a non-finite `origin` or `direction`, a zero `direction` or a `range`
/// that is not a number >= 0.
std::optional<double> nearest_crossing(const TriangleMesh& mesh, const Vec3& origin, const Vec3& direction,
                                       double range);

}  // namespace cariesim
