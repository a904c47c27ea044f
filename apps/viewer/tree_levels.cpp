#include "tree_levels.hpp"

#include <algorithm>

namespace cariesim::viewer {

std::vector<uint8_t> node_levels(const SphereTree& tree) {
  // Walk down from the root; a child index outside the array or seen twice is ignored.
  std::vector<uint8_t> levels(tree.nodes.size(), 0);
  if (tree.nodes.empty()) return levels;
  std::vector<bool> seen(tree.nodes.size(), false);
  std::vector<uint32_t> stack{0};
  seen[0] = true;
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    const SphereNode& node = tree.nodes[i];
    if (node.is_leaf()) continue;
    for (uint32_t c = node.first; c < node.first + node.count && c < tree.nodes.size(); ++c) {
      if (seen[c]) continue;
      seen[c] = true;
      levels[c] = static_cast<uint8_t>(std::min(levels[i] + 1, 255));
      stack.push_back(c);
    }
  }
  return levels;
}

std::vector<uint32_t> level_cut(const SphereTree& tree, const std::vector<uint8_t>& levels, int level) {
  std::vector<uint32_t> cut;
  for (std::size_t i = 0; i < tree.nodes.size() && i < levels.size(); ++i) {
    const int l = levels[i];
    if (l == level || (l < level && tree.nodes[i].is_leaf())) cut.push_back(static_cast<uint32_t>(i));
  }
  return cut;
}

}  // namespace cariesim::viewer
