// Trees are built in two steps: a builder makes the leaves (build_leaves), build_tree makes the levels
// above them once. The octree's levels are the cells above its leaves, put back from the cells' paths;
// a tight tree's are fitted; leaf i of the tree is leaf i of what the builder made.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/build.hpp"
#include "spheretree/test_shapes.hpp"

namespace cariesim {
namespace {

constexpr int kDepth = 3;

// An octree of depth kDepth over a 2 mm ball (a few hundred leaves).
struct Octree {
  LevelSet shape = LevelSet::from_mesh(testing::make_icosphere(2.0, 4, Vec3(0.3, -0.2, 0.1)), 0.05, 0.25);
  TreeParams params;
  TreeLeaves leaves;
  Octree() {
    params.mode = TreeMode::Octree;
    params.depth = kDepth;
    leaves = build_leaves(shape, params);
  }
};

// The centre of the cell with `path` at `level`, summed from the root's octants (not the builder's
// recurrence).
Vec3 cell_center(const OctreeFrame& frame, uint32_t path, int level) {
  Vec3 c = frame.center;
  for (int l = 1; l <= level; ++l) {
    const uint32_t octant = (path >> (3 * (level - l))) & 7u;
    const double half = 0.5 * frame.edge / std::ldexp(1.0, l);
    c += half * Vec3((octant & 1) ? 1.0 : -1.0, (octant & 2) ? 1.0 : -1.0, (octant & 4) ? 1.0 : -1.0);
  }
  return c;
}

// The message of the cariesim::Error `f` throws (empty when it throws none).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

TEST(TreeLeaves, OctreeLeavesAreCellsOfTheDeepestLevelInPathOrder) {
  const Octree o;
  const TreeLeaves& t = o.leaves;
  EXPECT_EQ(t.mode, TreeMode::Octree);
  ASSERT_GT(t.leaves.size(), 50u);
  ASSERT_EQ(t.cells.size(), t.leaves.size());
  EXPECT_EQ(t.octree.depth, kDepth);
  EXPECT_GT(t.octree.edge, 4.0);  // the ball's 4 mm, padded
  const double radius = 0.5 * std::sqrt(3.0) * t.octree.edge / std::ldexp(1.0, kDepth);
  for (std::size_t i = 0; i < t.leaves.size(); ++i) {
    if (i > 0) {
      EXPECT_LT(t.cells[i - 1], t.cells[i]) << i;
    }
    EXPECT_LT(t.cells[i], 1u << (3 * kDepth)) << i;
    const LeafSphere& l = t.leaves[i];
    EXPECT_LT((l.center.cast<double>() - cell_center(t.octree, t.cells[i], kDepth)).norm(), 1e-5) << i;
    EXPECT_NEAR(l.radius, radius, 1e-5) << i;
    // Surface cells get their tangent before the hierarchy exists.
    if (l.flags & kLeafOnExposedSurface) {
      EXPECT_EQ(l.tangents.count, 1) << i;
    } else {
      EXPECT_EQ(l.flags, kLeafInterior) << i;
      EXPECT_EQ(l.tangents.count, 0) << i;
    }
  }
}

TEST(BuildTree, OctreeLevelsAreTheCellsAboveTheLeaves) {
  const Octree o;
  const TreeLeaves& t = o.leaves;
  const SphereTree tree = build_tree(t);
  ASSERT_FALSE(tree.empty());
  EXPECT_EQ(tree.mode, TreeMode::Octree);
  EXPECT_EQ(tree.levels, kDepth + 1);
  EXPECT_EQ(check_tree(tree), "");
  ASSERT_EQ(tree.leaf_count(), t.leaves.size());

  // One node per distinct cell of each level.
  std::vector<std::size_t> expected(kDepth + 1);
  for (int level = 0; level <= kDepth; ++level) {
    std::set<uint32_t> prefixes;
    for (uint32_t path : t.cells) prefixes.insert(path >> (3 * (kDepth - level)));
    expected[static_cast<std::size_t>(level)] = prefixes.size();
  }
  EXPECT_EQ(tree.nodes_per_level(), expected);

  // Walking down from the root: each node is its cell's sphere, siblings in octant order, and every
  // leaf is the builder's leaf of its own cell.
  std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // node, path
  std::vector<int> level_of(tree.nodes.size(), 0);
  std::size_t leaves_seen = 0;
  while (!stack.empty()) {
    const auto [index, path] = stack.back();
    stack.pop_back();
    const SphereNode& node = tree.nodes[index];
    const int level = level_of[index];
    EXPECT_LT((node.center.cast<double>() - cell_center(t.octree, path, level)).norm(), 1e-5) << index;
    EXPECT_NEAR(node.radius, 0.5 * std::sqrt(3.0) * t.octree.edge / std::ldexp(1.0, level), 1e-5) << index;
    if (node.is_leaf()) {
      ASSERT_EQ(level, kDepth) << index;
      ASSERT_LT(node.leaf, t.leaves.size());
      EXPECT_EQ(t.cells[node.leaf], path) << index;
      EXPECT_EQ(tree.leaf_nodes[node.leaf], index);
      const LeafSphere& l = t.leaves[node.leaf];
      EXPECT_EQ(node.center, l.center);
      EXPECT_EQ(node.radius, l.radius);
      EXPECT_EQ(node.flags, l.flags);
      EXPECT_EQ(tree.leaf_depth[node.leaf], l.depth);
      EXPECT_EQ(tree.leaf_tangents[node.leaf].count, l.tangents.count);
      ++leaves_seen;
      continue;
    }
    int previous = -1;
    for (uint32_t k = 0; k < node.count; ++k) {
      const uint32_t child = node.first + k;
      const Vec3 d = tree.nodes[child].center.cast<double>() - node.center.cast<double>();
      const int octant = (d.x() > 0 ? 1 : 0) | (d.y() > 0 ? 2 : 0) | (d.z() > 0 ? 4 : 0);
      EXPECT_GT(octant, previous) << "children of node " << index << " out of octant order";
      previous = octant;
      level_of[child] = level + 1;
      stack.emplace_back(child, (path << 3) | static_cast<uint32_t>(octant));
    }
  }
  EXPECT_EQ(leaves_seen, t.leaves.size());
}

TEST(BuildTree, RefusesOctreeCellsThatAreNotTheLeaves) {
  const Octree o;
  TreeLeaves t = o.leaves;
  t.cells.pop_back();
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("cells for"), std::string::npos);

  t = o.leaves;
  std::swap(t.cells[3], t.cells[4]);
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("leaf 4"), std::string::npos);

  t = o.leaves;
  t.cells[7] = 1u << (3 * kDepth);
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("leaf 7"), std::string::npos);

  t = o.leaves;
  t.leaves[5].center.x() += static_cast<float>(0.25 * t.octree.edge);
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("leaf 5 does not lie in its cell"),
            std::string::npos);

  t = o.leaves;
  t.leaves[6].radius = std::nanf("");
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("leaf 6"), std::string::npos);

  t = o.leaves;
  t.octree.depth = 8;
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("depth 8"), std::string::npos);

  t = o.leaves;
  t.octree.edge = std::nan("");
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("root cell"), std::string::npos);

  // Cells belong to an octree only; seam leaves to a tight tree only.
  t = o.leaves;
  t.mode = TreeMode::Tight;
  EXPECT_NE(error_of([&] { (void)build_tree(t); }).find("no octree cells"), std::string::npos);
  t = o.leaves;
  const std::vector<LesionShape> no_lesions;
  EXPECT_NE(error_of([&] { add_seam_leaves(t, {}, o.shape, no_lesions, o.params); }).find("octree"),
            std::string::npos);
  EXPECT_EQ(t.leaves.size(), o.leaves.leaves.size());
}

TEST(BuildTree, TightTreeLeafIIsTheBuildersLeafI) {
  const LevelSet shape = LevelSet::from_mesh(testing::make_icosphere(1.5, 4), 0.05, 0.25);
  TreeParams p;
  p.tolerance = 0.03;
  const TreeLeaves t = build_leaves(shape, p);
  EXPECT_EQ(t.mode, TreeMode::Tight);
  EXPECT_TRUE(t.cells.empty());
  ASSERT_GT(t.leaves.size(), 20u);
  const SphereTree tree = build_tree(t, p.branching);
  EXPECT_EQ(tree.mode, TreeMode::Tight);
  EXPECT_EQ(check_tree(tree), "");
  ASSERT_EQ(tree.leaf_count(), t.leaves.size());
  for (std::size_t i = 0; i < t.leaves.size(); ++i) {
    const LeafSphere& l = t.leaves[i];
    const SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
    EXPECT_EQ(node.center, l.center) << i;
    EXPECT_EQ(node.radius, l.radius) << i;
    EXPECT_EQ(node.flags, l.flags) << i;
    EXPECT_EQ(tree.leaf_depth[i], l.depth) << i;
    EXPECT_EQ(tree.leaf_tangents[i].count, l.tangents.count) << i;
    // The tight builder gives every surface leaf the tangents it touches.
    if (l.flags & kLeafOnExposedSurface) {
      EXPECT_GE(l.tangents.count, 1) << i;
    }
  }
  EXPECT_TRUE(build_tree(TreeLeaves{}).empty());
}

TEST(SetLeafTangents, GivesSurfaceLeavesWithoutOneTheRadialNormal) {
  const Vec3 center(0.5, 0.0, -0.5);
  const LevelSet shape = LevelSet::from_mesh(testing::make_icosphere(2.0, 4, center), 0.05, 0.25);
  std::vector<LeafSphere> leaves(3);
  leaves[0].center = (center + Vec3(0.0, 1.5, 0.0)).cast<float>();  // surface, no tangent
  leaves[0].radius = 0.4f;
  leaves[0].flags = kLeafOnExposedSurface;
  leaves[1] = leaves[0];  // surface, already tangent: kept
  leaves[1].tangents.count = 1;
  leaves[1].tangents.normal[0] = Vec3f::UnitX();
  leaves[2].center = center.cast<float>();  // interior filler: none
  leaves[2].radius = 1.0f;
  leaves[2].flags = kLeafInterior;
  set_leaf_tangents(leaves, shape);
  ASSERT_EQ(leaves[0].tangents.count, 1);
  EXPECT_GT(leaves[0].tangents.normal[0].y(), 0.98f);
  EXPECT_EQ(leaves[1].tangents.normal[0], Vec3f::UnitX());
  EXPECT_EQ(leaves[2].tangents.count, 0);
}

}  // namespace
}  // namespace cariesim
