#pragma once
// Brute-force references for the sphere-tree tests: distance to a union of leaves, overlap of two
// trees.

#include <algorithm>
#include <cmath>
#include <limits>

#include "cariesim/spheretree/sphere_tree.hpp"

namespace cariesim::testing {

/// min over leaves of |p - c| - r (negative inside a leaf), by brute force.
inline double distance_to_leaves(const SphereTree& tree, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (uint32_t n : tree.leaf_nodes) {
    const SphereNode& s = tree.nodes[n];
    best = std::min(best, (p - s.center.cast<double>()).norm() - s.radius);
  }
  return best;
}

/// The leaf (node) whose sphere surface is closest to p.
inline const SphereNode& nearest_leaf(const SphereTree& tree, const Vec3& p) {
  const SphereNode* best = &tree.nodes[tree.leaf_nodes.front()];
  double best_d = std::numeric_limits<double>::infinity();
  for (uint32_t n : tree.leaf_nodes) {
    const SphereNode& s = tree.nodes[n];
    const double d = std::abs((p - s.center.cast<double>()).norm() - s.radius);
    if (d < best_d) {
      best_d = d;
      best = &s;
    }
  }
  return *best;
}

/// Largest overlap depth r_a + r_b - |c_a - c_b| between a leaf of `a` and a leaf of `b` (mm).
inline double max_overlap(const SphereTree& a, const SphereTree& b) {
  double worst = -std::numeric_limits<double>::infinity();
  for (uint32_t i : a.leaf_nodes) {
    const SphereNode& s = a.nodes[i];
    for (uint32_t j : b.leaf_nodes) {
      const SphereNode& t = b.nodes[j];
      worst = std::max(worst, double(s.radius) + t.radius - (s.center - t.center).norm());
    }
  }
  return worst;
}

}  // namespace cariesim::testing
