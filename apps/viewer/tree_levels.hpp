#pragma once
/// Sphere trees by level for the overlay (docs/design.md §5): the nodes a tree shows at a chosen level.

#include <cstdint>
#include <vector>

#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim::viewer {

/// The level of every node (root 0), in node order.
std::vector<uint8_t> node_levels(const SphereTree& tree);

/// The cut of the tree at `level`: every node on that level plus every leaf above it, so the spheres
/// shown always cover the whole object. Levels past the deepest give the leaves.
std::vector<uint32_t> level_cut(const SphereTree& tree, const std::vector<uint8_t>& levels, int level);

}  // namespace cariesim::viewer
