#pragma once
/// Mesh checks shared inside the geometry module (not part of the public interface).

#include <cstddef>
#include <string>

#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

/// Number of intersecting pairs of triangles that share no edge. Pairs sharing a vertex count when
/// they cross away from it; coplanar overlaps are not detected. Uses a uniform grid over the bounds.
std::size_t count_self_intersections(const TriangleMesh& mesh);

namespace detail {
/// validate_mesh's work, adding to `report` (load_mesh fills some fields before calling it).
void validate_into(TriangleMesh& mesh, const std::string& what, MeshReport& report,
                   const MeshLoadOptions& options);
}  // namespace detail

}  // namespace cariesim
