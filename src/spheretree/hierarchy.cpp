#include "cariesim/spheretree/hierarchy.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/build.hpp"

namespace cariesim {

namespace {

constexpr int kMinBranching = 2;
constexpr int kMaxBranching = 8;
// Refinement passes of the enclosing-sphere centre (Badoiu-Clarkson steps); with at most 8 children
// this costs a few hundred flops per inner node and shrinks the Ritter/box result by a few percent.
constexpr int kRefineIterations = 48;

// A sphere in double precision while the hierarchy is being fitted.
struct Ball {
  Vec3 c;    // mm
  double r;  // mm
};

// A node waiting for its children: which leaves (a range of `order`) it covers and its depth.
struct Task {
  uint32_t node;
  uint32_t begin;
  uint32_t end;
  int depth;
};

// Radius of the smallest sphere centred at `c` that holds every ball.
double enclosing_radius(const Vec3& c, const Ball* balls, int n) {
  double r = 0.0;
  for (int i = 0; i < n; ++i) r = std::max(r, (balls[i].c - c).norm() + balls[i].r);
  return r;
}

// The smallest ball holding two balls.
Ball merge(const Ball& a, const Ball& b) {
  const Vec3 d = b.c - a.c;
  const double dist = d.norm();
  if (dist + b.r <= a.r) return a;
  if (dist + a.r <= b.r) return b;
  const double r = 0.5 * (dist + a.r + b.r);
  return {a.c + d * ((r - a.r) / dist), r};
}

// Ritter's bounding sphere adapted to balls: start from the two mutually far balls, grow to hold the rest.
Ball ritter(const Ball* balls, int n) {
  auto farthest_from = [&](const Vec3& p) {
    int best = 0;
    double best_d = -1.0;
    for (int i = 0; i < n; ++i) {
      const double d = (balls[i].c - p).norm() + balls[i].r;
      if (d > best_d) {
        best_d = d;
        best = i;
      }
    }
    return best;
  };
  const int a = farthest_from(balls[0].c);
  const int b = farthest_from(balls[a].c);
  Ball s = merge(balls[a], balls[b]);
  for (int i = 0; i < n; ++i) s = merge(s, balls[i]);
  return s;
}

// A tight ball holding `balls`: the better of the box-centred and Ritter spheres, then refined by
// moving the centre toward the farthest ball (Badoiu-Clarkson), keeping the smallest radius seen.
Ball enclose(const Ball* balls, int n) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  for (int i = 0; i < n; ++i) {
    lo = lo.cwiseMin(balls[i].c - Vec3::Constant(balls[i].r));
    hi = hi.cwiseMax(balls[i].c + Vec3::Constant(balls[i].r));
  }
  const Vec3 box_c = 0.5 * (lo + hi);
  Ball best{box_c, enclosing_radius(box_c, balls, n)};
  const Ball rit = ritter(balls, n);
  const double rit_r = enclosing_radius(rit.c, balls, n);
  if (rit_r < best.r) best = {rit.c, rit_r};

  // Refinement: step toward the far point of the farthest ball with a shrinking step.
  Vec3 c = best.c;
  for (int t = 1; t <= kRefineIterations; ++t) {
    int far = 0;
    double far_d = -1.0;
    for (int i = 0; i < n; ++i) {
      const double d = (balls[i].c - c).norm() + balls[i].r;
      if (d > far_d) {
        far_d = d;
        far = i;
      }
    }
    if (far_d < best.r) best = {c, far_d};
    const Vec3 dir = balls[far].c - c;
    const double len = dir.norm();
    const Vec3 far_point = len > 0.0 ? Vec3(balls[far].c + dir * (balls[far].r / len)) : balls[far].c;
    c += (far_point - c) / static_cast<double>(t + 1);
  }
  const double final_r = enclosing_radius(c, balls, n);
  if (final_r < best.r) best = {c, final_r};
  return best;
}

// The exact double value of a float vector, read back through volatile storage: GCC 12's SLP
// vectorizer at -O2 reuses the unrounded doubles for a double->float->double round trip in the
// same function (seen on Debian's g++ 12.2), which would fit the radius around the wrong centre.
Vec3 widen_exactly(const Vec3f& v) {
  const volatile float x = v.x();
  const volatile float y = v.y();
  const volatile float z = v.z();
  return {x, y, z};
}

// Stores `b` as a float sphere that still holds every ball after rounding the centre.
void store_conservatively(SphereNode& node, const Ball& b, const Ball* balls, int n) {
  node.center = b.c.cast<float>();
  const double r = enclosing_radius(widen_exactly(node.center), balls, n);
  float rf = static_cast<float>(r);
  if (static_cast<double>(rf) < r) rf = std::nextafter(rf, std::numeric_limits<float>::infinity());
  node.radius = rf;
}

// Splits order[begin, end) into `k` groups of near-equal size by recursive median cuts along the
// longest axis of the centres' bounding box; appends the group boundaries to `cuts`. With k <= the
// range's size every group gets at least one leaf.
void split(std::vector<uint32_t>& order, std::span<const LeafSphere> leaves, uint32_t begin, uint32_t end,
           int k, std::vector<uint32_t>& cuts) {
  if (k <= 1 || end - begin <= 1) {
    cuts.push_back(end);
    return;
  }
  // Longest axis of the centres' box.
  Vec3f lo = Vec3f::Constant(std::numeric_limits<float>::infinity());
  Vec3f hi = -lo;
  for (uint32_t i = begin; i < end; ++i) {
    lo = lo.cwiseMin(leaves[order[i]].center);
    hi = hi.cwiseMax(leaves[order[i]].center);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  // Cut at the count that keeps the subgroups proportional to their share of the k groups.
  const int k_left = k / 2;
  const uint32_t n = end - begin;
  const uint32_t mid = begin + static_cast<uint32_t>((static_cast<uint64_t>(n) * k_left) / k);
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                   [&](uint32_t a, uint32_t b) {
                     const float ca = leaves[a].center[axis];
                     const float cb = leaves[b].center[axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  split(order, leaves, begin, mid, k_left, cuts);
  split(order, leaves, mid, end, k - k_left, cuts);
}

// Rejects leaves that would poison the tree (non-finite centre, negative or non-finite radius).
void check_leaves(std::span<const LeafSphere> leaves) {
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    const LeafSphere& l = leaves[i];
    if (!l.center.allFinite()) {
      throw Error("build_hierarchy: leaf " + std::to_string(i) + ": centre is not finite");
    }
    if (!std::isfinite(l.radius) || l.radius < 0.0f) {
      throw Error("build_hierarchy: leaf " + std::to_string(i) + ": radius " + std::to_string(l.radius) +
                  " mm is not a finite non-negative number");
    }
  }
}

}  // namespace

SphereTree build_hierarchy(std::span<const LeafSphere> leaves, int branching) {
  if (branching < kMinBranching || branching > kMaxBranching) {
    throw Error("build_hierarchy: branching " + std::to_string(branching) + " is outside [2, 8]");
  }
  if (leaves.size() >= std::numeric_limits<uint32_t>::max() / 2) {
    throw Error("build_hierarchy: " + std::to_string(leaves.size()) + " leaves is too many");
  }
  check_leaves(leaves);
  SphereTree tree;
  if (leaves.empty()) return tree;

  const auto n = static_cast<uint32_t>(leaves.size());
  std::vector<uint32_t> order(n);
  for (uint32_t i = 0; i < n; ++i) order[i] = i;
  tree.nodes.reserve(2 * static_cast<std::size_t>(n));
  tree.leaf_nodes.assign(n, 0);
  tree.leaf_depth.assign(n, 0.0f);
  tree.leaf_tangents.assign(n, LeafTangents{});

  // Top-down, breadth first: each task's children are appended together, so they are contiguous
  // and every level is stored before the next.
  std::vector<Task> queue;
  queue.reserve(2 * static_cast<std::size_t>(n));
  tree.nodes.emplace_back();
  queue.push_back({0, 0, n, 0});
  std::vector<uint32_t> cuts;
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const Task task = queue[q];
    tree.levels = std::max(tree.levels, task.depth + 1);
    SphereNode& node = tree.nodes[task.node];
    // A single leaf: copy it.
    if (task.end - task.begin == 1) {
      const uint32_t li = order[task.begin];
      const LeafSphere& l = leaves[li];
      node.center = l.center;
      node.radius = l.radius;
      node.count = 0;
      node.material = l.material;
      node.leaf = li;
      node.flags = l.flags;
      tree.leaf_nodes[li] = task.node;
      tree.leaf_depth[li] = l.depth;
      tree.leaf_tangents[li] = l.tangents;
      continue;
    }
    // An inner node: cut its range into up to `branching` groups, one child each.
    cuts.clear();
    const int groups =
        static_cast<int>(std::min<uint32_t>(static_cast<uint32_t>(branching), task.end - task.begin));
    split(order, leaves, task.begin, task.end, groups, cuts);
    const auto first = static_cast<uint32_t>(tree.nodes.size());
    node.first = first;
    node.count = static_cast<uint16_t>(cuts.size());
    uint32_t begin = task.begin;
    for (std::size_t g = 0; g < cuts.size(); ++g) {
      tree.nodes.emplace_back();
      queue.push_back({first + static_cast<uint32_t>(g), begin, cuts[g], task.depth + 1});
      begin = cuts[g];
    }
  }

  // Bottom-up: children have larger indices than their parent, so a reverse sweep fits every inner
  // sphere after its children.
  std::array<Ball, kMaxBranching> balls{};
  for (std::size_t i = tree.nodes.size(); i-- > 0;) {
    SphereNode& node = tree.nodes[i];
    if (node.is_leaf()) continue;
    const int count = node.count;
    for (int k = 0; k < count; ++k) {
      const SphereNode& child = tree.nodes[node.first + k];
      balls[k] = {child.center.cast<double>(), static_cast<double>(child.radius)};
    }
    store_conservatively(node, enclose(balls.data(), count), balls.data(), count);
  }
  return tree;
}

SphereTree build_tool_tree(const std::vector<ToolSphere>& spheres, int branching) {
  std::vector<LeafSphere> leaves;
  leaves.reserve(spheres.size());
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const ToolSphere& s = spheres[i];
    if (!s.center.allFinite() || !std::isfinite(s.radius) || s.radius < 0.0) {
      throw Error("build_tool_tree: tool sphere " + std::to_string(i) +
                  " has a non-finite centre or a negative radius");
    }
    LeafSphere leaf{};
    leaf.center = s.center.cast<float>();
    leaf.radius = static_cast<float>(s.radius);
    leaves.push_back(leaf);
  }
  return build_hierarchy(leaves, branching);
}

}  // namespace cariesim
