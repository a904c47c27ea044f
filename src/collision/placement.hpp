#pragma once
// What a PlacedTool holds (placement.cpp): the tool tree's tables fitted once (parents, leaves below,
// capsules, reach), the current placement (pose, margins) and the world copies of the nodes, made as
// the queries reach them, and the queries' scratch (per-leaf quota counters). Private to the
// collision module: PlacedTool (collision/collide.hpp) is its public handle, and the queries
// (traversal.cpp, nearest.cpp) read the tables through it. One thread uses a placement at a time.

#include <cstdint>
#include <span>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/common/math.hpp"
#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim::collision_detail {

/// A counter of one traversal, stamped: it counts only while `stamp` is the traversal's, so the
/// tables need no clearing between traversals.
struct LeafHits {
  uint32_t stamp = 0;
  uint32_t count = 0;
};

/// The tool placed in the world for one query (see PlacedTool). The world copies of a node (centre,
/// capsule, and with margins by reach its inflated radius and leaf margin) are made when a query
/// splits its parent (reach_children), so a query near the tip moves a few dozen nodes, not the tree.
struct ToolPlacement {
  /// Checks the tree (children after their parent, leaf indices within the leaf table, at most
  /// 65 535 leaves) and fits its tables; throws Error naming the node otherwise.
  explicit ToolPlacement(const SphereTree& tool);

  const SphereTree* tool;
  Pose pose;

  // World copies, per node (per leaf for leaf_margin), filled as the queries reach nodes.
  std::vector<Vec3> centers;
  std::vector<double> radii;         ///< mm, inflated by the leaf margins (pruning and the pair test)
  std::vector<double> leaf_margin;   ///< mm, per leaf
  std::vector<uint32_t> leaf_quota;  ///< per leaf, or empty (PlacedTool::set_leaf_quota)

  // The queries' scratch (collide()): per tool leaf, pairs reported for the object being traversed;
  // per tool node, how many leaves below it are capped (have left out a pair) for that object.
  std::vector<LeafHits> leaf_hits;
  std::vector<LeafHits> node_caps;
  uint32_t hit_stamp = 0;

  // The tree's tables, fitted once.
  std::vector<uint32_t> parent;        ///< per node; the root's is itself
  std::vector<uint32_t> leaves_below;  ///< per node; 1 for a leaf
  std::vector<double> max_reach;       ///< mm, per node: the largest reach of a leaf below it (its own)
  // Capsule bounds (PlacedTool::capsule_a): tool-frame segment start, direction and true radius per
  // node, and their world copies (the radius inflated) made with the centres.
  std::vector<Vec3> tool_capsule_a;
  std::vector<Vec3> tool_capsule_d;
  std::vector<double> tool_capsule_radius;  ///< mm
  std::vector<Vec3> capsule_a;              ///< world
  std::vector<Vec3> capsule_d;              ///< world
  std::vector<double> capsule_inv_dd;       ///< 1/mm², 0 for a point
  std::vector<double> capsule_radii;        ///< mm, inflated
  std::vector<uint8_t> has_capsule;

  // Lazy placement: the rotation of the current pose, and per inner node the placement whose stamp
  // it carries when its children were moved.
  Mat3 rot = Mat3::Identity();
  uint32_t place_stamp = 0;
  std::vector<uint32_t> children_placed;
  // Margins by reach (place(pose, ReachMargins)): radii and leaf margins are made with the centres.
  bool reach_margins = false;
  ReachMargins margins;

  /// The three placements of PlacedTool::place.
  void place(const Pose& at, double margin);
  void place(const Pose& at, std::span<const double> margin_per_leaf);
  void place(const Pose& at, const ReachMargins& rule);
  /// Moves every node still waiting, so that the world copies are the whole tool at `pose`.
  void place_all();
  /// A fresh stamp for one object's traversal (the tables are cleared when the stamps wrap).
  uint32_t next_hit_stamp();
  /// Moves the children of inner node `node` to the current pose (centres, capsules, and with margins
  /// by reach their radii and leaf margins) unless this placement already has: the queries call it
  /// before they split a tool node.
  void reach_children(uint32_t node) {
    if (children_placed[node] != place_stamp) place_children(node);
  }
  /// The world centre of one node, moving it (with its siblings) first when it is not yet.
  const Vec3& center(uint32_t node) {
    const uint32_t up = parent[node];
    if (up != node) reach_children(up);
    return centers[node];
  }

 private:
  void fit_capsules();
  // The world position of node i (centre, and capsule where it has one) at the current pose.
  void place_node(std::size_t i);
  void place_children(uint32_t node);
  // Starts a placement: the root is moved, every other node waits for reach_children().
  void start_placement(const Pose& at);
};

}  // namespace cariesim::collision_detail
