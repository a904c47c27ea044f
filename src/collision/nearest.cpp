// The nearest-pair queries: closest() and any_within(), a branch and bound over the placed tool's
// tree and the objects' trees; sphere_closest(), one sphere against one object's tree.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "cariesim/collision/collide.hpp"
#include "collision/placement.hpp"
#include "collision/traversal.hpp"

namespace cariesim {

using collision_detail::kStackSize;
using collision_detail::prefetch_children;
using collision_detail::ToolPlacement;

namespace {

struct BoundedPair {
  double bound;  // mm
  uint32_t tool;
  uint32_t object;
};

// Lower bound of the gap between any leaves under a tool node and an object node (true radii);
// the exact gap for two leaves.
inline double gap_bound(const Vec3* tool_centers, const SphereNode* tool_nodes,
                        const SphereNode* object_nodes, uint32_t t, uint32_t o) {
  const SphereNode& on = object_nodes[o];
  return (tool_centers[t] - on.center.cast<double>()).norm() - static_cast<double>(tool_nodes[t].radius) -
         static_cast<double>(on.radius);
}

// Branch and bound over the tool and the masked objects' trees (closest() and any_within()): with
// `first`, returns at the first leaf pair within the search radius.
ClosestPair bounded_search(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                           double search_mm, WorkBudget* budget, bool first) {
  ClosestPair best;
  best.gap = std::numeric_limits<double>::infinity();
  ToolPlacement& p = tool.placement();
  const SphereTree& tree = *p.tool;
  if (tree.empty() || std::isnan(search_mm)) return best;
  const SphereNode* tn = tree.nodes.data();
  const Vec3* tc = p.centers.data();  // a split tool node's children are moved first
  // Branch and bound: a pair is explored only while its lower bound beats the best gap so far
  // (initially the search radius); children are pushed far-to-near so the nearest is explored first.
  double bound_limit = search_mm;
  std::array<BoundedPair, kStackSize> stack;
  const std::size_t n = std::min<std::size_t>(objects.size(), 64);
  for (std::size_t i = 0; i < n; ++i) {
    if (((mask >> i) & 1u) == 0 || objects[i].tree.empty()) continue;
    const SphereNode* on = objects[i].tree.nodes.data();
    int top = 0;
    stack[top++] = {gap_bound(tc, tn, on, 0, 0), 0, 0};
    while (top > 0) {
      const BoundedPair pair = stack[--top];
      if (!(pair.bound < bound_limit)) continue;
      if (budget != nullptr && !budget->take()) {
        best.complete = false;
        return best;
      }
      const SphereNode& a = tn[pair.tool];
      const SphereNode& b = on[pair.object];
      // Two leaves: the bound is the exact gap.
      if (a.is_leaf() && b.is_leaf()) {
        bound_limit = pair.bound;
        best = {pair.bound, static_cast<uint16_t>(a.leaf), static_cast<uint16_t>(i), pair.object};
        if (first) return best;
        continue;
      }
      // Split the larger sphere; keep the children that can still beat the best gap.
      const bool split_tool = !a.is_leaf() && (b.is_leaf() || a.radius >= b.radius);
      if (split_tool) p.reach_children(pair.tool);
      const SphereNode& split = split_tool ? a : b;
      std::array<BoundedPair, 8> kids;
      int kid_count = 0;
      for (uint32_t c = split.first; c < split.first + split.count; ++c) {
        const uint32_t t = split_tool ? c : pair.tool;
        const uint32_t o = split_tool ? pair.object : c;
        const double lb = gap_bound(tc, tn, on, t, o);
        if (!(lb < bound_limit)) continue;
        if (kid_count < static_cast<int>(kids.size())) {
          kids[kid_count++] = {lb, t, o};
        } else if (top < kStackSize) {
          stack[top++] = {lb, t, o};  // more than 8 children: the rest go unsorted
        }
      }
      // At most 8 children: an insertion sort, far first.
      for (int k = 1; k < kid_count; ++k) {
        const BoundedPair moving = kids[k];
        int j = k;
        for (; j > 0 && kids[j - 1].bound < moving.bound; --j) kids[j] = kids[j - 1];
        kids[j] = moving;
      }
      for (int k = 0; k < kid_count && top < kStackSize; ++k) stack[top++] = kids[k];
    }
  }
  return best;
}

}  // namespace

ClosestPair closest(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                    double search_mm, WorkBudget* budget) {
  return bounded_search(tool, objects, mask, search_mm, budget, false);
}

ClosestPair any_within(PlacedTool& tool, std::span<const CollisionObject> objects, ObjectMask mask,
                       double search_mm, WorkBudget* budget) {
  return bounded_search(tool, objects, mask, search_mm, budget, true);
}

double sphere_closest(const Vec3& center, double radius, const CollisionObject& object, double search_mm,
                      WorkBudget* budget) {
  double best = std::numeric_limits<double>::infinity();
  if (object.tree.empty() || std::isnan(search_mm)) return best;
  const SphereNode* nodes = object.tree.nodes.data();
  const uint32_t skip = object.surface_only ? kLeafInterior : 0u;
  double limit = search_mm;
  const auto bound = [&](uint32_t o) {
    return (center - nodes[o].center.cast<double>()).norm() - radius - static_cast<double>(nodes[o].radius);
  };
  // Depth first, branch and bound on the gap's lower bound.
  std::array<uint32_t, kStackSize> stack;
  int top = 0;
  if (bound(0) < limit) stack[top++] = 0;
  while (top > 0) {
    const uint32_t o = stack[--top];
    if (budget != nullptr && !budget->take()) return -std::numeric_limits<double>::infinity();
    const SphereNode& n = nodes[o];
    if (n.is_leaf()) {
      const double gap = bound(o);
      if (!(n.flags & skip) && gap < limit) best = limit = gap;
      continue;
    }
    for (uint32_t c = n.first; c < n.first + n.count; ++c) {
      if (!(bound(c) < limit && top < kStackSize)) continue;
      stack[top++] = c;
      prefetch_children<1>(nodes, nodes[c]);
    }
  }
  return best;
}

}  // namespace cariesim
