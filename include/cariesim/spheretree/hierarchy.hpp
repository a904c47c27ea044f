#pragma once
/// Builds the inner levels of a sphere tree over a given set of leaf spheres: top-down median
/// splits, `branching` children per inner node, each inner sphere bounding its children's spheres.
/// Used by the tight mode (build_tree) and for the tool's chain.

#include <cstdint>
#include <span>
#include <vector>

#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim {

/// A leaf before the hierarchy exists.
struct LeafSphere {
  Vec3f center;  ///< mm
  float radius;  ///< mm
  uint16_t material = 0;
  uint32_t flags = 0;       ///< LeafFlags
  float depth = 0.0f;       ///< mm below the outer surface
  LeafTangents tangents{};  ///< the surfaces the sphere is tangent to (none for fillers)
};

/// Builds a tree whose leaves are exactly `leaves` (leaf index i = leaves[i]). `branching` in [2, 8].
/// An empty input gives an empty tree.
SphereTree build_hierarchy(std::span<const LeafSphere> leaves, int branching = 4);

}  // namespace cariesim
