#include "cariesim/spheretree/cache.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/hierarchy.hpp"
#include "spheretree/test_shapes.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;

// A fresh cache folder per test, removed afterwards.
class CacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cariesim-cache-test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A built tree with every field set, and a display mesh.
  static CachedPart sample_part() {
    std::vector<LeafSphere> leaves;
    for (int i = 0; i < 300; ++i) {
      leaves.push_back({Vec3f(std::sin(i) * 3.0f, std::cos(i * 0.7f) * 2.0f, i * 0.01f), 0.05f + 0.001f * i,
                        static_cast<uint16_t>(i % 5), (i % 3 == 0) ? kLeafInterior : kLeafOnExposedSurface,
                        0.1f * (i % 7)});
    }
    for (std::size_t i = 0; i < leaves.size(); ++i) {
      leaves[i].tangents.normal[0] = Vec3f(std::cos(0.1f * i), std::sin(0.1f * i), 0.0f);
      leaves[i].tangents.normal[1] = Vec3f(0.0f, 0.0f, i % 2 ? 1.0f : -1.0f);
      leaves[i].tangents.count = static_cast<uint8_t>(i % 3);
      leaves[i].tangents.wall_mask = static_cast<uint8_t>(i % 4);
    }
    CachedPart part;
    part.tree = build_hierarchy(leaves, 4);
    part.tree.mode = TreeMode::Tight;
    part.display = testing::make_icosphere(2.0, 2);
    return part;
  }

  static std::vector<char> read(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  }
  static void write(const fs::path& p, const std::vector<char>& bytes) {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  [[nodiscard]] fs::path entry() const {
    for (const auto& e : fs::directory_iterator(dir_)) return e.path();
    return {};
  }

  fs::path dir_;
};

void expect_same(const CachedPart& a, const CachedPart& b) {
  ASSERT_EQ(a.tree.nodes.size(), b.tree.nodes.size());
  for (std::size_t i = 0; i < a.tree.nodes.size(); ++i) {
    const SphereNode& x = a.tree.nodes[i];
    const SphereNode& y = b.tree.nodes[i];
    EXPECT_EQ(x.center, y.center);
    EXPECT_EQ(x.radius, y.radius);
    EXPECT_EQ(x.first, y.first);
    EXPECT_EQ(x.count, y.count);
    EXPECT_EQ(x.material, y.material);
    EXPECT_EQ(x.leaf, y.leaf);
    EXPECT_EQ(x.flags, y.flags);
  }
  EXPECT_EQ(a.tree.leaf_nodes, b.tree.leaf_nodes);
  EXPECT_EQ(a.tree.leaf_depth, b.tree.leaf_depth);
  ASSERT_EQ(a.tree.leaf_tangents.size(), b.tree.leaf_tangents.size());
  for (std::size_t i = 0; i < a.tree.leaf_tangents.size(); ++i) {
    EXPECT_EQ(a.tree.leaf_tangents[i].normal, b.tree.leaf_tangents[i].normal);
    EXPECT_EQ(a.tree.leaf_tangents[i].count, b.tree.leaf_tangents[i].count);
    EXPECT_EQ(a.tree.leaf_tangents[i].wall_mask, b.tree.leaf_tangents[i].wall_mask);
  }
  EXPECT_EQ(a.tree.mode, b.tree.mode);
  EXPECT_EQ(a.tree.levels, b.tree.levels);
  EXPECT_EQ(a.display.vertices, b.display.vertices);
  EXPECT_EQ(a.display.triangles, b.display.triangles);
}

TEST(BuildKey, SameInputsSameKeyAnyChangeAnotherKey) {
  const auto key = [](double tol, int64_t depth, std::string_view file) {
    return BuildKey().add(file).add(tol).add(depth).value();
  };
  EXPECT_EQ(key(0.015, 4, "tooth_30.stl"), key(0.015, 4, "tooth_30.stl"));
  EXPECT_NE(key(0.015, 4, "tooth_30.stl"), key(0.016, 4, "tooth_30.stl"));
  EXPECT_NE(key(0.015, 4, "tooth_30.stl"), key(0.015, 5, "tooth_30.stl"));
  EXPECT_NE(key(0.015, 4, "tooth_30.stl"), key(0.015, 4, "tooth_31.stl"));
  // Strings carry their length, so splitting them differently changes the key.
  EXPECT_NE(BuildKey().add("ab").add("c").value(), BuildKey().add("a").add("bc").value());
  EXPECT_EQ(BuildKey().add(0.0).value(), BuildKey().add(-0.0).value());
  const std::vector<float> data{1.0f, 2.0f};
  EXPECT_NE(BuildKey().add(data.data(), 8).value(), BuildKey().add(data.data(), 4).value());
  EXPECT_NE(BuildKey().value(), BuildKey().add(int64_t{0}).value());
}

TEST_F(CacheTest, StoreThenLoadGivesTheSameTree) {
  const TreeCache cache(dir_);
  EXPECT_FALSE(cache.load(42).has_value());
  const CachedPart part = sample_part();
  cache.store(42, part);
  const auto loaded = cache.load(42);
  ASSERT_TRUE(loaded.has_value());
  expect_same(part, *loaded);
  EXPECT_EQ(check_tree(loaded->tree), "");
  EXPECT_FALSE(cache.load(43).has_value());
  // Only the entry remains (no temporary files).
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 1u);
  // Storing again replaces the entry.
  CachedPart other = sample_part();
  other.tree.nodes[0].material = 3;
  cache.store(42, other);
  EXPECT_EQ(cache.load(42)->tree.nodes[0].material, 3);
}

TEST_F(CacheTest, EmptyTreeRoundTrips) {
  const TreeCache cache(dir_);
  cache.store(7, CachedPart{});
  const auto loaded = cache.load(7);
  ASSERT_TRUE(loaded.has_value());
  EXPECT_TRUE(loaded->tree.empty());
  EXPECT_TRUE(loaded->display.triangles.empty());
}

TEST_F(CacheTest, CorruptEntriesAreIgnoredAndRemoved) {
  const TreeCache cache(dir_);
  const CachedPart part = sample_part();
  cache.store(5, part);
  const fs::path file = entry();
  const std::vector<char> good = read(file);
  ASSERT_GT(good.size(), 100u);

  // Truncations at many lengths, single flipped bytes anywhere, garbage, an empty file.
  std::vector<std::vector<char>> bad;
  for (std::size_t n : {std::size_t(0), std::size_t(3), std::size_t(20), good.size() / 2, good.size() - 1}) {
    bad.emplace_back(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(n));
  }
  std::mt19937 rng(9);
  for (int i = 0; i < 40; ++i) {
    std::vector<char> flipped = good;
    flipped[rng() % flipped.size()] ^= static_cast<char>(1 + rng() % 255);
    bad.push_back(flipped);
  }
  std::vector<char> garbage(good.size());
  for (char& c : garbage) c = static_cast<char>(rng());
  bad.push_back(garbage);
  std::vector<char> longer = good;
  longer.push_back('x');
  bad.push_back(longer);

  for (std::size_t i = 0; i < bad.size(); ++i) {
    write(file, bad[i]);
    EXPECT_FALSE(cache.load(5).has_value()) << "variant " << i;
    EXPECT_FALSE(fs::exists(file)) << "variant " << i << " was not removed";
  }
  // A well-formed file stored under another key does not answer for this one.
  write(file, good);
  cache.store(6, part);
  fs::path other;
  for (const auto& e : fs::directory_iterator(dir_))
    if (e.path() != file) other = e.path();
  ASSERT_FALSE(other.empty());
  write(other, good);
  EXPECT_FALSE(cache.load(6).has_value());
  // And the original still loads.
  EXPECT_TRUE(cache.load(5).has_value());
}

TEST_F(CacheTest, UnwritableFolderIsAWarningNotAnError) {
  fs::create_directories(dir_.parent_path());
  write(dir_, {'x'});  // a file where the folder should be
  const TreeCache cache(dir_ / "sub");
  EXPECT_NO_THROW(cache.store(1, sample_part()));
  EXPECT_FALSE(cache.load(1).has_value());
  fs::remove(dir_);
}

TEST(TreeCacheDir, FollowsTheEnvironment) {
  const char* saved = std::getenv("CARIESIM_CACHE_DIR");
  const std::string keep = saved ? saved : "";
  ::setenv("CARIESIM_CACHE_DIR", "/tmp/cariesim-explicit", 1);
  EXPECT_EQ(TreeCache::default_dir(), fs::path("/tmp/cariesim-explicit"));
  ::unsetenv("CARIESIM_CACHE_DIR");
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  const std::string keep_xdg = xdg ? xdg : "";
  ::setenv("XDG_CACHE_HOME", "/tmp/xdg", 1);
  EXPECT_EQ(TreeCache::default_dir(), fs::path("/tmp/xdg/cariesim"));
  ::unsetenv("XDG_CACHE_HOME");
  EXPECT_EQ(TreeCache::default_dir().filename(), fs::path("cariesim"));
  if (xdg) ::setenv("XDG_CACHE_HOME", keep_xdg.c_str(), 1);
  if (saved) ::setenv("CARIESIM_CACHE_DIR", keep.c_str(), 1);
  EXPECT_EQ(TreeCache(fs::path("/x/y")).dir(), fs::path("/x/y"));
}

}  // namespace
}  // namespace cariesim
