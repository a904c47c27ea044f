// Sphere trees by level (apps/viewer/tree_levels.cpp) on a hand-made tree and on a built one.
#include "viewer/tree_levels.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace {

using cariesim::SphereNode;
using cariesim::SphereTree;
using cariesim::viewer::level_cut;
using cariesim::viewer::node_levels;

// root(0) -> {1 leaf, 2}; 2 -> {3 leaf, 4 leaf}.
SphereTree small_tree() {
  SphereTree t;
  t.nodes.resize(5);
  t.nodes[0].first = 1;
  t.nodes[0].count = 2;
  t.nodes[2].first = 3;
  t.nodes[2].count = 2;
  return t;
}

TEST(TreeLevels, LevelsOfAHandMadeTree) {
  const SphereTree t = small_tree();
  EXPECT_EQ(node_levels(t), (std::vector<uint8_t>{0, 1, 1, 2, 2}));
}

// A cut holds the level's nodes and the leaves above it: it always covers the object.
TEST(TreeLevels, CutKeepsShallowLeaves) {
  const SphereTree t = small_tree();
  const auto levels = node_levels(t);
  EXPECT_EQ(level_cut(t, levels, 0), (std::vector<uint32_t>{0}));
  EXPECT_EQ(level_cut(t, levels, 1), (std::vector<uint32_t>{1, 2}));
  EXPECT_EQ(level_cut(t, levels, 2), (std::vector<uint32_t>{1, 3, 4}));
  EXPECT_EQ(level_cut(t, levels, 9), (std::vector<uint32_t>{1, 3, 4}));
}

// On a built tree: the levels agree with nodes_per_level, and the deepest cut is every leaf.
TEST(TreeLevels, AgreesWithABuiltTree) {
  cariesim::BuildOptions options;
  options.cache_dir = std::filesystem::path(CARIESIM_BINARY_DIR) / "test-cache";
  const cariesim::Model model = cariesim::build_model(cariesim::load_scene("friction-block"), options);
  ASSERT_FALSE(model.objects.empty());
  const SphereTree& tree = model.objects.front().tree;
  const auto levels = node_levels(tree);
  const auto per_level = tree.nodes_per_level();
  for (std::size_t l = 0; l < per_level.size(); ++l)
    EXPECT_EQ(static_cast<std::size_t>(std::count(levels.begin(), levels.end(), static_cast<uint8_t>(l))),
              per_level[l])
        << "level " << l;
  EXPECT_EQ(level_cut(tree, levels, tree.levels).size(), tree.leaf_count());
}

}  // namespace
