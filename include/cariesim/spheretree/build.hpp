#pragma once
/// Sphere-tree construction in two modes (DESIGN.md §3) and the surface-deviation measure.
///
/// octree (paper fidelity): the bounding cube split 2x2x2 per level; a cell is kept when it holds
///   surface or lies inside; its sphere is centred in the cell with radius (sqrt(3)/2) * edge.
///   Level L holds at most 8^L leaves (4096 at level 4).
/// tight (default): inscribed spheres under the surface, radius = distance to the surface, placed
///   greedily until every surface sample is within `tolerance` of the union; inner nodes bound their
///   children.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "cariesim/common/progress.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/spheretree/level_set.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

struct TreeParams {
  TreeMode mode = TreeMode::Tight;
  int depth = 4;                 ///< octree: number of subdivision levels
  double tolerance = 0.015;      ///< mm, tight: target surface deviation of the leaf union
  double max_radius = 1.0;       ///< mm, tight: largest surface leaf
  double min_radius = 0.02;      ///< mm, tight: smallest surface leaf
  bool fill_interior = true;     ///< tight: add large filler spheres deep inside
  std::size_t max_leaves = 50000;  ///< tight: hard cap (the build reports when it was reached)
  int branching = 4;             ///< children per inner node of the hierarchy
};

/// Builds a tree of the solid bounded by `shape` (its negative region).
SphereTree build_sphere_tree(const LevelSet& shape, const TreeParams& params,
                             const ProgressFn& progress = {});

/// Builds the tool's tree from its sphere chain (leaves in chain order, tip first).
SphereTree build_tool_tree(const std::vector<ToolSphere>& spheres, int branching = 4);

/// Sets leaf_depth (depth of each leaf centre below `outer`'s surface, mm) and the surface flags:
/// kLeafOnExposedSurface when the leaf touches `outer`'s zero set, kLeafOnLesionWall when it touches
/// an internal boundary instead, kLeafInterior when it touches neither within `touch_mm`.
void classify_leaves(SphereTree& tree, const LevelSet& outer, double touch_mm);

/// Sets each leaf's material from a callback given the leaf centre (mm) and its depth (mm).
void assign_materials(SphereTree& tree,
                      const std::function<uint16_t(const Vec3& center, float depth)>& material_of);

/// Distance between the union of leaves and a surface, both ways (DESIGN.md §3).
struct Deviation {
  double p50 = 0.0;  ///< mm
  double p95 = 0.0;  ///< mm
  double max = 0.0;  ///< mm
  double max_poke_out = 0.0;   ///< mm, largest amount a leaf reaches beyond the surface
  double max_fall_short = 0.0; ///< mm, largest gap between a surface point and the union
  std::size_t samples = 0;
};
/// Samples `samples` points uniformly on `surface` (seeded) and measures |distance to the union of
/// leaves|; also every leaf's poke-out beyond `surface` (via `shape`). p50/p95/max are over both sets.
Deviation measure_deviation(const SphereTree& tree, const TriangleMesh& surface, const LevelSet& shape,
                            std::size_t samples = 100000, uint64_t seed = 1);

/// Checks the structural invariants: every child sphere inside its parent (within `slack_mm`),
/// contiguous children, leaf tables consistent. Returns an empty string when valid, else the reason.
std::string check_tree(const SphereTree& tree, double slack_mm = 1e-4);

}  // namespace cariesim
