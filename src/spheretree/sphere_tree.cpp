#include "cariesim/spheretree/sphere_tree.hpp"

#include <utility>

namespace cariesim {

// Depth-first walk from the root with an explicit stack, counting nodes per depth. It does not rely
// on the nodes being stored level by level, so it works for every builder.
std::vector<std::size_t> SphereTree::nodes_per_level() const {
  std::vector<std::size_t> counts;
  if (nodes.empty()) return counts;
  std::vector<std::pair<uint32_t, std::size_t>> stack{{0u, 0u}};
  while (!stack.empty()) {
    const auto [index, depth] = stack.back();
    stack.pop_back();
    if (counts.size() <= depth) counts.resize(depth + 1, 0);
    ++counts[depth];
    const SphereNode& node = nodes[index];
    for (uint32_t k = 0; k < node.count; ++k) stack.emplace_back(node.first + k, depth + 1);
  }
  return counts;
}

}  // namespace cariesim
