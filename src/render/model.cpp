#include "cariesim/render/model.hpp"

#include <algorithm>

namespace cariesim {

// Rigid: a tree with leaves, each of a known, rigid material.
bool rigid_object(const SphereTree& tree, const std::vector<Material>& materials) {
  if (tree.empty()) return false;
  return std::all_of(tree.leaf_nodes.begin(), tree.leaf_nodes.end(), [&](uint32_t node) {
    const uint16_t material = tree.nodes[node].material;
    return material < materials.size() && materials[material].rigid();
  });
}

// One bit per object the rule calls rigid (a Model has at most 64 objects: State refuses more).
ObjectMask rigid_objects(const Model& model) {
  ObjectMask mask = 0;
  const std::size_t count = std::min<std::size_t>(model.objects.size(), 64);
  for (std::size_t i = 0; i < count; ++i)
    if (rigid_object(model.objects[i].tree, model.defaults.materials)) mask |= ObjectMask{1} << i;
  return mask;
}

}  // namespace cariesim
