#pragma once
/// Sphere trees: the one representation of every object and of the tool (paper §2.2).
///
/// Layout: a flat array of nodes, node 0 is the root, the children of an inner node are contiguous
/// (`first` .. `first + count`). Inner nodes bound their children; leaves carry a material index: the
/// model builder assigns it (assign_materials), the haptic step looks it up; the tree knows no material.
/// The traversal touches only `SphereNode` (hot, 32 bytes); per-leaf extras live in separate arrays.

#include <array>
#include <cstdint>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim {

/// One node of a sphere tree. 32 bytes.
struct SphereNode {
  Vec3f center = Vec3f::Zero();  ///< mm, in the tree's frame (world for objects, tool frame for the tool)
  float radius = 0.0f;           ///< mm
  uint32_t first = 0;            ///< index of the first child (inner node); unused for a leaf
  uint16_t count = 0;            ///< number of children; 0 marks a leaf
  uint16_t material = 0;         ///< leaf: index into the model's material table
  uint32_t leaf = 0;             ///< leaf: index into the per-leaf arrays (SphereTree::leaf_*)
  uint32_t flags = 0;            ///< leaf: LeafFlags bits

  [[nodiscard]] bool is_leaf() const { return count == 0; }
};
static_assert(sizeof(SphereNode) == 32, "SphereNode is the hot traversal record; keep it 32 bytes");

/// Per-leaf flag bits.
enum LeafFlags : uint32_t {
  kLeafOnExposedSurface = 1u << 0,  ///< tangent to the object's outer surface
  kLeafOnLesionWall = 1u << 1,      ///< tangent to an internal boundary (healthy/caries interface)
  kLeafInterior = 1u << 2,          ///< filler sphere deep inside the object
};

enum class TreeMode : uint8_t { Tight, Octree };

/// Where a leaf touches its solid's surface: up to two tangent points (a sphere in a thin layer touches
/// its top and its floor; one at an edge touches both faces). Cold data, 28 bytes.
struct LeafTangents {
  std::array<Vec3f, 2> normal{Vec3f::Zero(), Vec3f::Zero()};  ///< unit outward normals at the tangent points
  uint8_t count = 0;      ///< how many of `normal` are set (0 for interior fillers)
  uint8_t wall_mask = 0;  ///< bit k: tangent k lies on an internal (lesion) boundary, not the outer surface
};

/// A built tree and what it took to build it.
struct SphereTree {
  std::vector<SphereNode> nodes;       ///< node 0 is the root
  std::vector<uint32_t> leaf_nodes;    ///< leaf index -> node index
  std::vector<float> leaf_depth;       ///< mm, leaf index -> depth of the centre below the object's outer surface
  /// leaf index -> the surfaces the leaf is tangent to. Compliant contacts measure depth against the
  /// tangent plane that faces the tool, so that all leaves of one flat patch push the same way.
  std::vector<LeafTangents> leaf_tangents;
  TreeMode mode = TreeMode::Tight;
  int levels = 0;                      ///< depth of the deepest leaf + 1 (a lone root has 1 level)

  [[nodiscard]] std::size_t leaf_count() const { return leaf_nodes.size(); }
  [[nodiscard]] bool empty() const { return nodes.empty(); }
  /// Number of nodes on each level (level 0 = root).
  [[nodiscard]] std::vector<std::size_t> nodes_per_level() const;
};

}  // namespace cariesim
