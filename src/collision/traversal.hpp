#pragma once
// What the tree descents of the collision module share (traversal.cpp, nearest.cpp): their stack
// size, the pruning slack, and the prefetch of a waiting node's children.

#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim::collision_detail {

// Pending node pairs of a dual traversal. Depth first, each split pushes at most 7 siblings that wait
// while the first is explored, so a stack of this size holds any pair of trees whose levels sum to
// 146 or less (balanced trees of 10^6 leaves have about 10 levels each).
inline constexpr int kStackSize = 1024;
// mm; node pairs are kept when they overlap within this slack, so rounding never prunes a pair.
inline constexpr double kPruneSlack = 1e-6;

// Fetches the first `lines` cache lines (two 32-byte nodes each) of an inner node's children, which
// will be read when the node waiting on a stack is split. A scanned tooth's tree is megabytes, and
// the hottest instruction of the traversal's profile waited on a child's centre. The dual traversal
// fetches two lines, the single sphere's search one: what each was measured with.
template <int lines>
[[gnu::always_inline]] inline void prefetch_children(const SphereNode* nodes, const SphereNode& node) {
  static_assert(lines == 1 || lines == 2);
  if (node.is_leaf()) return;
  const SphereNode* children = nodes + node.first;
  __builtin_prefetch(children);
  if (lines == 2 && node.count > 2) __builtin_prefetch(children + 2);
}

}  // namespace cariesim::collision_detail
