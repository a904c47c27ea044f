#pragma once
/// Mesh checks shared inside the geometry module (not part of the public interface).

#include <cstddef>
#include <string>
#include <vector>

#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

/// Number of intersecting pairs of triangles that share no edge: an edge of one passes from one side
/// of the other's plane to the other through it, its edges or corners. Pairs sharing a vertex count
/// when they cross away from it; coplanar overlaps are not detected. Uses a uniform grid over the
/// bounds.
std::size_t count_self_intersections(const TriangleMesh& mesh);

/// A closed shell found inside another (find_nested_shell).
struct NestedShells {
  bool found = false;
  bool too_costly = false;        ///< the shells' bounds overlap so much that checking them would take over
                                  ///< `max_work` triangle tests; nothing was decided
  uint32_t inner = 0, outer = 0;  ///< component numbers
  std::size_t inner_triangles = 0, outer_triangles = 0;
};
/// The first shell (connected component, `component` per triangle, `components` of them) lying
/// inside another: a hollow solid (a closed surface around an inner cavity) or a part within a part.
/// The shells must be closed and cross nothing (count_self_intersections). A shell is inside another
/// when the other's winding number at two of three of its vertices is +-1. Stops after `max_work`
/// triangle tests (too_costly).
NestedShells find_nested_shell(const TriangleMesh& mesh, const std::vector<uint32_t>& component,
                               std::size_t components, std::size_t max_work);

namespace detail {
/// validate_mesh's work, adding to `report` (load_mesh fills some fields before calling it).
void validate_into(TriangleMesh& mesh, const std::string& what, MeshReport& report,
                   const MeshLoadOptions& options);
}  // namespace detail

}  // namespace cariesim
