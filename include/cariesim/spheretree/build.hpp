#pragma once
/// Sphere-tree construction in two modes (docs/design.md §3) and the surface-deviation measure.
///
/// octree (paper fidelity): the bounding cube split 2x2x2 per level; a cell is kept when it holds
///   surface or lies inside; its sphere is centred in the cell with radius (sqrt(3)/2) * edge.
///   Level L holds at most 8^L leaves (4096 at level 4).
/// tight (default): inscribed spheres under the surface, radius = distance to the surface, placed
///   greedily until every surface sample is within `tolerance` of the union; inner nodes bound their
///   children.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "cariesim/common/hash.hpp"
#include "cariesim/common/progress.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/spheretree/hierarchy.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "cariesim/spheretree/level_set.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

struct TreeParams {
  TreeMode mode = TreeMode::Tight;
  int depth = 4;                   ///< octree: number of subdivision levels
  double tolerance = 0.015;        ///< mm, tight: target surface deviation of the leaf union
  double max_radius = 1.0;         ///< mm, tight: largest surface leaf
  double min_radius = 0.02;        ///< mm, tight: smallest surface leaf
  bool fill_interior = true;       ///< tight: add large filler spheres deep inside
  std::size_t max_leaves = 50000;  ///< tight: hard cap (the build reports when it was reached)
  int branching = 4;               ///< children per inner node of the hierarchy
};
/// A key hashes every field of TreeParams (common/hash.hpp: a new field must be counted here).
template <>
inline constexpr std::size_t kKeyFields<TreeParams> = 8;

/// Level-set resolution for building a tree of a mesh: the voxel the mode's fidelity needs (tight:
/// (10/3) * tolerance, 0.05 mm for 0.015 mm; octree: 1/8 of a leaf cell), coarsened when the band
/// would exceed a memory budget (a 100 x 100 x 20 mm cube stays around 20 million band voxels).
struct LevelSetResolution {
  double voxel = 0.05;      ///< mm
  double half_band = 0.25;  ///< mm, each side of the surface
};
/// Throws cariesim::Error for an empty mesh.
LevelSetResolution choose_resolution(const TriangleMesh& mesh, const TreeParams& params);

/// An octree's root cell: the cube every leaf cell subdivides.
struct OctreeFrame {
  Vec3 center = Vec3::Zero();  ///< mm, the root cell's centre
  double edge = 0.0;           ///< mm, the root cell's edge
  int depth = 0;               ///< levels below the root; the leaves are the cells of the deepest
};

/// What a tree builder makes: the leaves of a tree before the levels above them, so that more leaves
/// (add_seam_leaves) join them before build_tree builds the hierarchy once.
struct TreeLeaves {
  TreeMode mode = TreeMode::Tight;
  std::vector<LeafSphere> leaves;  ///< leaf index i = leaves[i]
  /// Octree only (empty for a tight tree): each leaf's cell as its path from the root, the octant of
  /// every level in 3 bits (bit 0 +x, bit 1 +y, bit 2 +z), the first level's octant highest, strictly
  /// increasing (the builder's order). The levels above the leaves are these cells' ancestors.
  std::vector<uint32_t> cells;
  OctreeFrame octree;  ///< octree only: the root cell of `cells`

  [[nodiscard]] bool empty() const { return leaves.empty(); }
};

/// Builds the leaves of a tree of the solid bounded by `shape` (its negative region). Tight mode
/// resolves sphere radii beyond the narrow band through a coarser rebuild of the same surface, so the
/// band may be thin (a few voxels). Leaves come out flagged kLeafOnExposedSurface (surface leaves) or
/// kLeafInterior (fillers, octree cells inside), depth relative to `shape`, every surface leaf with a
/// tangent (set_leaf_tangents); classify_leaves refines both against the object's outer surface once
/// the tree is built. Throws cariesim::Error for bad parameters. Empty for an empty `shape`.
TreeLeaves build_leaves(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress = {});

/// The tree over `leaves` (leaf index i = leaves.leaves[i]), its inner levels built once: tight,
/// spheres fitted over median splits of `branching` children (build_hierarchy); octree, the cells
/// above the leaves (the paper's hierarchy: each inner node the sphere around its cell, radius
/// (sqrt(3)/2) * edge, whatever `branching`). Throws cariesim::Error naming what is wrong (and the leaf)
/// for octree cells that are not the leaves' (another count, out of order, deeper than the depth, a leaf
/// outside its cell, a bad root cell or depth), for cells given with tight leaves, and for the leaves
/// build_hierarchy refuses. Empty leaves give an empty tree.
SphereTree build_tree(const TreeLeaves& leaves, int branching = 4);

/// build_tree(build_leaves(shape, params, progress), params.branching).
SphereTree build_sphere_tree(const LevelSet& shape, const TreeParams& params,
                             const ProgressFn& progress = {});

/// Gives surface leaves that have no tangents one from the solid's distance field (build_leaves does
/// this for the octree's cells; the tight builder records the surfaces each sphere touches).
void set_leaf_tangents(std::span<LeafSphere> leaves, const LevelSet& shape);

/// Builds the tool's tree from its sphere chain (leaves in chain order, tip first).
SphereTree build_tool_tree(const std::vector<ToolSphere>& spheres, int branching = 4);

/// Sets leaf_depth (depth of each leaf centre below `outer`'s surface, mm), marks each leaf tangent as
/// lying on `outer`'s surface or on an internal boundary (LeafTangents::wall_mask; judged at the
/// tangent point within `touch_mm`), and flags the leaf kLeafOnExposedSurface when some tangent lies on
/// the outer surface, kLeafOnLesionWall when some lies on an internal boundary (both can hold), and
/// kLeafInterior when it touches neither (fillers).
void classify_leaves(SphereTree& tree, const LevelSet& outer, double touch_mm);

/// Sets each leaf's material from a callback given the leaf centre (mm) and its depth (mm).
void assign_materials(SphereTree& tree,
                      const std::function<uint16_t(const Vec3& center, float depth)>& material_of);

/// How the seam between the parts of an object cut by lesions is closed (docs/scene-format.md, "Lesions").
struct SeamParams {
  double band_mm = 0.75;  ///< mm each side of a lesion's border over which the uncut surface is covered again
  double overlap_mm = 0.1;  ///< mm, how far a seam leaf may reach across a cut into the neighbouring part
  double tolerance = 0.01;  ///< mm, largest coverage tolerance of the seam leaves
  /// Seam leaves follow the surface to this fraction of the tree's own tolerance (at most `tolerance`):
  /// a rigid probe's 0.05 mm tip feels the dimples between leaves as tangential force.
  double tolerance_fraction = 1.0 / 3.0;
  /// mm, the seam leaves' coverage tolerance for a tree of tolerance `tree_tolerance_mm`.
  [[nodiscard]] double tolerance_for(double tree_tolerance_mm) const {
    return std::min(tolerance, tolerance_fraction * tree_tolerance_mm);
  }
};

/// Seam leaves. Cutting an object into healthy and caries parts (paper §2.2) gives both
/// parts a sharp edge where a lesion meets the surface, which inscribed spheres cannot fill: their
/// union leaves a groove along every border. These leaves cover the uncut surface of `object` within
/// `seam.band_mm` of every lesion's border (to `seam.tolerance_for(params.tolerance)`), tangent to it,
/// each inside the object and reaching at most `seam.overlap_mm` across a cut; each belongs to the part
/// holding its centre. Returned per part: [0] healthy, [1 + k] the caries of lesions[k] (the first lesion
/// holding a point owns it, as the CSG cuts them). Leaves come flagged kLeafOnExposedSurface with their
/// tangent normals.
std::vector<std::vector<LeafSphere>> build_seam_leaves(const LevelSet& object,
                                                       std::span<const LesionShape> lesions,
                                                       const TreeParams& params, const SeamParams& seam = {},
                                                       const ProgressFn& progress = {});

/// Adds a part's seam leaves (build_seam_leaves) to its leaves (a tight tree's: an octree's leaves are
/// its cells, and an octree part is refused). The part's own leaves that poke out of the uncut surface
/// (`object`) within `seam.band_mm` of a border are first shrunk to poke out no more than the seam
/// leaves may (a fifth of their tolerance); a leaf shrunk to nothing is dropped. build_tree then builds
/// the part's tree.
void add_seam_leaves(TreeLeaves& part, std::span<const LeafSphere> seam_leaves, const LevelSet& object,
                     std::span<const LesionShape> lesions, const TreeParams& params,
                     const SeamParams& seam = {});

/// Distance between the union of leaves and a surface, both ways (docs/design.md §3).
struct Deviation {
  double p50 = 0.0;             ///< mm
  double p95 = 0.0;             ///< mm
  double max = 0.0;             ///< mm
  double max_poke_out = 0.0;    ///< mm, largest amount a leaf reaches beyond the surface
  double max_fall_short = 0.0;  ///< mm, largest gap between a surface point and the union
  std::size_t samples = 0;
};
/// Samples `samples` points uniformly on `surface` (seeded) and measures |distance to the union of
/// leaves| (min over leaves of |x - c| - r, pruned through the tree); also every leaf's poke-out
/// beyond the surface, r + D(c) with D the signed distance of `shape`. p50/p95/max are over the
/// sample distances together with the leaves that do poke out (poke-out > 0). Throws
/// cariesim::Error for an empty tree or surface.
Deviation measure_deviation(const SphereTree& tree, const TriangleMesh& surface, const LevelSet& shape,
                            std::size_t samples = 100000, uint64_t seed = 1);

/// Deviation across a lesion's border: the union of the leaves of every part of one
/// object (`parts`: healthy and caries trees) against the object's uncut `surface`, on the band where
/// |border(x)| <= `half_width_mm` (mm; `border` is the lesion's signed distance, so the band runs
/// `half_width_mm` each side of the border along the surface); poke-outs beyond `shape` (the object's
/// level set) of the leaves whose poking cap (around the apex toward the nearest surface) reaches the
/// band. About `samples` band samples (seeded). Throws
/// cariesim::Error for an empty part, surface or band.
Deviation measure_seam_deviation(std::span<const SphereTree* const> parts, const TriangleMesh& surface,
                                 const LevelSet& shape, const std::function<double(const Vec3&)>& border,
                                 double half_width_mm, std::size_t samples = 100000, uint64_t seed = 1);

/// What `cariesim tree` reports about a build.
struct TreeReport {
  TreeMode mode = TreeMode::Tight;
  std::size_t leaves = 0;
  int levels = 0;
  std::vector<std::size_t> nodes_per_level;  ///< level 0 = root
  double build_seconds = 0.0;                ///< s, wall clock of the build
  Deviation deviation;
};
/// Collects a report from a built tree, its build time (s) and its measured deviation.
TreeReport make_tree_report(const SphereTree& tree, double build_seconds, const Deviation& deviation);
/// One-line JSON object: mode, leaves, levels, nodes_per_level, build_seconds and deviation_mm
/// {p50, p95, max, max_poke_out, max_fall_short, samples}.
std::string format_tree_report_json(const TreeReport& report);

/// Checks the structural invariants: every child sphere inside its parent (within `slack_mm`),
/// contiguous children, leaf tables consistent. Returns an empty string when valid, else the reason.
std::string check_tree(const SphereTree& tree, double slack_mm = 1e-4);

}  // namespace cariesim
