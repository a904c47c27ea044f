#include "cariesim/spheretree/hierarchy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/build.hpp"

namespace cariesim {
namespace {

// Random leaves in a box of `extent` mm with radii in [r_min, r_max] mm and distinct labels.
std::vector<LeafSphere> random_leaves(std::size_t n, uint32_t seed, float extent = 10.0f, float r_min = 0.05f,
                                      float r_max = 0.4f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-extent, extent);
  std::uniform_real_distribution<float> rad(r_min, r_max);
  std::vector<LeafSphere> leaves(n);
  for (std::size_t i = 0; i < n; ++i) {
    leaves[i].center = Vec3f(pos(rng), pos(rng), pos(rng));
    leaves[i].radius = rad(rng);
    leaves[i].material = static_cast<uint16_t>(i % 7);
    leaves[i].flags = static_cast<uint32_t>(i % 3 == 0 ? kLeafOnExposedSurface : kLeafInterior);
    leaves[i].depth = 0.01f * static_cast<float>(i % 100);
  }
  return leaves;
}

// Leaves on a curved sheet, like the surface band of a tooth.
std::vector<LeafSphere> sheet_leaves(std::size_t side) {
  std::vector<LeafSphere> leaves;
  for (std::size_t i = 0; i < side; ++i) {
    for (std::size_t j = 0; j < side; ++j) {
      LeafSphere l{};
      const float x = 0.2f * static_cast<float>(i);
      const float y = 0.2f * static_cast<float>(j);
      l.center = Vec3f(x, y, 0.3f * std::sin(x) * std::cos(y));
      l.radius = 0.15f;
      leaves.push_back(l);
    }
  }
  return leaves;
}

// Structural checks: every node reached once from the root, children inside their parents (within
// `slack` mm), every leaf reached once and its node carries the leaf's data unchanged.
void expect_valid(const SphereTree& tree, std::span<const LeafSphere> leaves, int branching,
                  double slack = 1e-9) {
  ASSERT_EQ(tree.leaf_count(), leaves.size());
  ASSERT_EQ(tree.leaf_depth.size(), leaves.size());
  std::vector<int> node_seen(tree.nodes.size(), 0);
  std::vector<int> leaf_seen(leaves.size(), 0);
  std::vector<uint32_t> stack{0};
  int max_depth = 0;
  std::vector<int> depth(tree.nodes.size(), 0);
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    ASSERT_LT(i, tree.nodes.size());
    ++node_seen[i];
    const SphereNode& node = tree.nodes[i];
    max_depth = std::max(max_depth, depth[i]);
    if (node.is_leaf()) {
      ASSERT_LT(node.leaf, leaves.size());
      ++leaf_seen[node.leaf];
      continue;
    }
    ASSERT_LE(node.count, branching);
    ASSERT_GE(node.count, 2);
    ASSERT_LE(node.first + node.count, tree.nodes.size());
    for (uint32_t k = 0; k < node.count; ++k) {
      const SphereNode& child = tree.nodes[node.first + k];
      const double reach = (child.center.cast<double>() - node.center.cast<double>()).norm() + child.radius;
      EXPECT_LE(reach, node.radius + slack) << "child " << node.first + k << " pokes out of node " << i;
      depth[node.first + k] = depth[i] + 1;
      stack.push_back(node.first + k);
    }
  }
  for (std::size_t i = 0; i < node_seen.size(); ++i) EXPECT_EQ(node_seen[i], 1) << "node " << i;
  for (std::size_t i = 0; i < leaf_seen.size(); ++i) {
    EXPECT_EQ(leaf_seen[i], 1) << "leaf " << i;
    const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
    ASSERT_TRUE(node.is_leaf());
    EXPECT_EQ(node.leaf, i);
    EXPECT_EQ(node.center, leaves[i].center);
    EXPECT_EQ(node.radius, leaves[i].radius);
    EXPECT_EQ(node.material, leaves[i].material);
    EXPECT_EQ(node.flags, leaves[i].flags);
    EXPECT_EQ(tree.leaf_depth[i], leaves[i].depth);
  }
  EXPECT_EQ(tree.levels, max_depth + 1);
}

// Smallest L with b^L >= n: the depth of a balanced b-ary tree over n leaves.
int balanced_depth(std::size_t n, int b) {
  int levels = 0;
  std::size_t cap = 1;
  while (cap < n) {
    cap *= static_cast<std::size_t>(b);
    ++levels;
  }
  return levels;
}

TEST(BuildHierarchy, EmptyInputGivesEmptyTree) {
  const SphereTree tree = build_hierarchy({}, 4);
  EXPECT_TRUE(tree.empty());
  EXPECT_EQ(tree.leaf_count(), 0u);
  EXPECT_EQ(tree.levels, 0);
  EXPECT_TRUE(tree.nodes_per_level().empty());
}

TEST(BuildHierarchy, SingleLeafIsTheRoot) {
  std::vector<LeafSphere> leaves = random_leaves(1, 3);
  const SphereTree tree = build_hierarchy(leaves, 4);
  ASSERT_EQ(tree.nodes.size(), 1u);
  EXPECT_TRUE(tree.nodes[0].is_leaf());
  EXPECT_EQ(tree.levels, 1);
  EXPECT_EQ(tree.nodes_per_level(), std::vector<std::size_t>{1});
  expect_valid(tree, leaves, 4);
}

TEST(BuildHierarchy, TwoSpheresGetTheirExactEnclosingSphere) {
  std::vector<LeafSphere> leaves(2);
  leaves[0].center = Vec3f(-3.0f, 1.0f, 2.0f);
  leaves[0].radius = 1.0f;
  leaves[1].center = Vec3f(3.0f, 1.0f, 2.0f);
  leaves[1].radius = 2.0f;
  const SphereTree tree = build_hierarchy(leaves, 2);
  // The smallest sphere holding both: diameter from x = -4 to x = 5.
  EXPECT_NEAR(tree.nodes[0].radius, 4.5, 1e-4);
  EXPECT_NEAR(tree.nodes[0].center.x(), 0.5, 1e-4);
  EXPECT_NEAR(tree.nodes[0].center.y(), 1.0, 1e-4);
  expect_valid(tree, leaves, 2);
}

TEST(BuildHierarchy, RandomLeavesAllBranchings) {
  for (int b = 2; b <= 8; ++b) {
    for (std::size_t n : {2u, 3u, 7u, 64u, 513u, 4000u}) {
      SCOPED_TRACE("branching " + std::to_string(b) + " n " + std::to_string(n));
      const std::vector<LeafSphere> leaves = random_leaves(n, static_cast<uint32_t>(n * 10 + b));
      const SphereTree tree = build_hierarchy(leaves, b);
      expect_valid(tree, leaves, b);
      EXPECT_EQ(tree.levels, balanced_depth(n, b) + 1);
      const std::vector<std::size_t> per_level = tree.nodes_per_level();
      EXPECT_EQ(per_level.size(), static_cast<std::size_t>(tree.levels));
      EXPECT_EQ(std::accumulate(per_level.begin(), per_level.end(), std::size_t{0}), tree.nodes.size());
      EXPECT_EQ(per_level.front(), 1u);
    }
  }
}

TEST(BuildHierarchy, InnerSpheresAreNoLooserThanTheBoxCentredSphere) {
  const std::vector<LeafSphere> leaves = sheet_leaves(40);
  const SphereTree tree = build_hierarchy(leaves, 4);
  expect_valid(tree, leaves, 4);
  // The box-centred bound of each inner node's children is one of the candidates, so the stored
  // sphere may not be larger than it (plus float rounding).
  int strictly_tighter = 0;
  for (const SphereNode& node : tree.nodes) {
    if (node.is_leaf()) continue;
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 hi = -lo;
    for (uint32_t k = 0; k < node.count; ++k) {
      const SphereNode& c = tree.nodes[node.first + k];
      lo = lo.cwiseMin(c.center.cast<double>() - Vec3::Constant(c.radius));
      hi = hi.cwiseMax(c.center.cast<double>() + Vec3::Constant(c.radius));
    }
    const Vec3 mid = 0.5 * (lo + hi);
    double r = 0.0;
    for (uint32_t k = 0; k < node.count; ++k) {
      const SphereNode& c = tree.nodes[node.first + k];
      r = std::max(r, (c.center.cast<double>() - mid).norm() + c.radius);
    }
    EXPECT_LE(node.radius, r + 1e-5);
    if (node.radius < r * 0.99) ++strictly_tighter;
  }
  EXPECT_GT(strictly_tighter, 0);
}

TEST(BuildHierarchy, CoincidentAndZeroRadiusLeaves) {
  std::vector<LeafSphere> leaves(37);
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    leaves[i].center = Vec3f(1.0f, 2.0f, 3.0f);
    leaves[i].radius = i % 2 == 0 ? 0.0f : 0.5f;
  }
  const SphereTree tree = build_hierarchy(leaves, 4);
  expect_valid(tree, leaves, 4);
  for (const SphereNode& node : tree.nodes) {
    EXPECT_TRUE(std::isfinite(node.radius));
    EXPECT_TRUE(node.center.allFinite());
  }
  EXPECT_NEAR(tree.nodes[0].radius, 0.5, 1e-5);
}

TEST(BuildHierarchy, FiftyThousandLeaves) {
  const std::vector<LeafSphere> leaves = random_leaves(50000, 11, 6.0f, 0.02f, 0.3f);
  const SphereTree tree = build_hierarchy(leaves, 4);
  expect_valid(tree, leaves, 4);
  EXPECT_EQ(tree.levels, balanced_depth(leaves.size(), 4) + 1);
}

TEST(BuildHierarchy, RejectsBadInput) {
  std::vector<LeafSphere> leaves = random_leaves(10, 5);
  EXPECT_THROW((void)build_hierarchy(leaves, 1), Error);
  EXPECT_THROW((void)build_hierarchy(leaves, 9), Error);
  leaves[4].radius = -1.0f;
  EXPECT_THROW((void)build_hierarchy(leaves, 4), Error);
  leaves[4].radius = 0.1f;
  leaves[7].center.y() = std::numeric_limits<float>::quiet_NaN();
  try {
    (void)build_hierarchy(leaves, 4);
    FAIL() << "a NaN centre was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("leaf 7"), std::string::npos) << e.what();
  }
}

TEST(BuildToolTree, LeavesFollowTheChainTipFirst) {
  std::vector<ToolSphere> chain;
  for (int i = 0; i < 150; ++i) {
    const double t = 0.05 * i;
    chain.push_back({Vec3(0.3 * std::sin(t), 0.0, 2.0 * t), 0.05 + 0.003 * i, static_cast<uint16_t>(i / 50)});
  }
  const SphereTree tree = build_tool_tree(chain, 4);
  ASSERT_EQ(tree.leaf_count(), chain.size());
  for (std::size_t i = 0; i < chain.size(); ++i) {
    const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
    EXPECT_EQ(node.leaf, i);
    EXPECT_EQ(node.center, chain[i].center.cast<float>());
    EXPECT_FLOAT_EQ(node.radius, static_cast<float>(chain[i].radius));
  }
  EXPECT_FLOAT_EQ(tree.nodes[tree.leaf_nodes[0]].radius, 0.05f);
  std::vector<LeafSphere> as_leaves;
  for (const ToolSphere& s : chain) {
    LeafSphere l{};
    l.center = s.center.cast<float>();
    l.radius = static_cast<float>(s.radius);
    as_leaves.push_back(l);
  }
  expect_valid(tree, as_leaves, 4);
  chain[3].radius = std::numeric_limits<double>::infinity();
  EXPECT_THROW((void)build_tool_tree(chain, 4), Error);
}

}  // namespace
}  // namespace cariesim
