// The tree cache's key holds every field of every parameter that makes a part: each field of each
// shape kind's parameters, of the pose, the tree settings and every lesion's shape, changed one at a
// time, misses a real cache that holds the unchanged part; and `mirrored` teeth, which the key once
// left out, are built anew through one cache instead of coming back unmirrored. (Materials are not
// part of a cached part: leaves are labelled after the cache.)
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "cariesim/common/hash.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/spheretree/cache.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;

// Calls visit(leaf) on every leaf field of `value`, descending into the structs that count their
// fields (kKeyFields), so that a field added to any of them is visited too.
template <typename T, typename F>
void for_each_leaf(T& value, F& visit) {
  if constexpr (kKeyFields < T >> 0) {
    for_each_field<kKeyFields<T>>(value, [&](auto& field) { for_each_leaf(field, visit); });
  } else {
    visit(value);
  }
}

template <typename T>
std::size_t leaf_count(T value) {
  std::size_t n = 0;
  auto count = [&n](auto&) { ++n; };
  for_each_leaf(value, count);
  return n;
}

// Changes one leaf to a different value of its type; a path becomes `other_file`.
struct Perturb {
  fs::path other_file;
  template <typename T>
  void operator()(T& v) const {
    if constexpr (std::is_same_v<T, bool>) {
      v = !v;
    } else if constexpr (std::is_enum_v<T>) {
      const auto u = static_cast<std::underlying_type_t<T>>(v);
      v = static_cast<T>(u == 0 ? 1 : u - 1);
    } else if constexpr (std::is_integral_v<T>) {
      v = static_cast<T>(v + 1);
    } else if constexpr (std::is_floating_point_v<T>) {
      v = v == 0.0 ? 0.25 : v * 1.25;
    } else if constexpr (std::is_same_v<T, fs::path>) {
      v = other_file;
    } else if constexpr (std::is_same_v<T, Quat>) {
      v = v * Quat(Eigen::AngleAxisd(0.1, Vec3::UnitZ()));
    } else if constexpr (std::is_same_v<T, std::optional<double>>) {
      v = v ? std::optional<double>(*v * 1.25) : std::optional<double>(0.05);
    } else if constexpr (requires { v.coeffRef(0); }) {
      v.coeffRef(0) += 0.125;  // an Eigen vector
    } else if constexpr (requires { v.push_back(typename T::value_type{}); }) {
      using Element = typename T::value_type;
      if (v.empty())
        v.push_back(Element::Constant(0.5));
      else
        v.front().coeffRef(0) += 0.125;
    } else {
      static_assert(sizeof(T) == 0, "Perturb: no change known for this type");
    }
  }
};

// `base` with its leaf `index` perturbed.
template <typename T>
T perturbed(T base, std::size_t index, const Perturb& perturb) {
  std::size_t i = 0;
  auto visit = [&](auto& leaf) {
    if (i++ == index) perturb(leaf);
  };
  for_each_leaf(base, visit);
  return base;
}

std::string kind_name(ShapeDesc::Kind kind) { return std::string(shape_kind_name(kind)); }

// A fresh folder per test, removed afterwards.
class CacheKeyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("cariesim_cache_key_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(CacheKeyTest, EveryFieldOfEveryShapeLesionAndTreeParameterMissesTheCache) {
  // Two mesh files of different content, and a copy of the first under another name.
  const fs::path cube = dir_ / "cube.stl";
  const fs::path box = dir_ / "box.stl";
  const fs::path same = dir_ / "same-cube.stl";
  save_stl(make_cuboid(Vec3(2, 2, 2)), cube);
  save_stl(make_cuboid(Vec3(2, 3, 2)), box);
  fs::copy_file(cube, same);
  CachedPart stored;
  stored.display = make_cuboid(Vec3(1, 1, 1));

  // Two lesions of different kinds (a polygon with vertices, a disk without).
  std::vector<LesionShape> lesions(2);
  lesions[0].kind = LesionShape::Kind::Polygon;
  lesions[0].polygon = LesionShape::square(1.0);
  lesions[1].kind = LesionShape::Kind::Disk;
  lesions[1].center = Vec3(0.5, 0.25, 1.0);
  ObjectDesc object;
  object.pose.p = Vec3(1, 2, 3);
  object.shape.file = cube;
  object.shape.gingiva.path = {Vec3(0, 0, 0), Vec3(5, 1, 0)};
  const TreeParams params;

  std::size_t misses = 0;
  for (const ShapeDesc::Kind kind :
       {ShapeDesc::Kind::Mesh, ShapeDesc::Kind::Cuboid, ShapeDesc::Kind::Molar, ShapeDesc::Kind::Premolar,
        ShapeDesc::Kind::Gingiva, ShapeDesc::Kind::Tongue}) {
    object.shape.kind = kind;
    const Perturb perturb{box};
    // A cache per kind: another kind's entries are other parts (changing the kind may lead to them).
    const TreeCache cache(dir_ / ("cache-" + kind_name(kind)));
    for (const int part : {-1, 0, 1}) {
      const uint64_t base = part_cache_key(object, params, lesions, part);
      cache.store(base, stored);
      ASSERT_TRUE(cache.load(base).has_value());
      EXPECT_EQ(part_cache_key(object, params, lesions, part), base) << "the key is not deterministic";
      const auto expect_miss = [&](const ObjectDesc& o, const TreeParams& p,
                                   const std::vector<LesionShape>& l, const std::string& what) {
        EXPECT_FALSE(cache.load(part_cache_key(o, p, l, part)).has_value())
            << kind_name(kind) << ", part " << part << ": changing " << what << " hits the cache";
        ++misses;
      };

      // Every field of the shape (every kind's parameters, the mesh file's content), of the pose, of
      // the tree settings (TreeParams and the voxel) and of each lesion's world shape.
      for (std::size_t i = 0; i < leaf_count(object.shape); ++i) {
        ObjectDesc o = object;
        o.shape = perturbed(object.shape, i, perturb);
        expect_miss(o, params, lesions, "shape field " + std::to_string(i));
      }
      for (std::size_t i = 0; i < leaf_count(object.pose); ++i) {
        ObjectDesc o = object;
        o.pose = perturbed(object.pose, i, perturb);
        expect_miss(o, params, lesions, "pose field " + std::to_string(i));
      }
      const TreeDesc tree{params, object.tree.voxel};
      for (std::size_t i = 0; i < leaf_count(tree); ++i) {
        const TreeDesc changed = perturbed(tree, i, perturb);
        ObjectDesc o = object;
        o.tree.voxel = changed.voxel;
        expect_miss(o, changed.params, lesions, "tree field " + std::to_string(i));
      }
      for (std::size_t k = 0; k < lesions.size(); ++k) {
        for (std::size_t i = 0; i < leaf_count(lesions[k]); ++i) {
          std::vector<LesionShape> l = lesions;
          l[k] = perturbed(lesions[k], i, perturb);
          expect_miss(object, params, l, "lesion " + std::to_string(k) + " field " + std::to_string(i));
        }
      }
      std::vector<LesionShape> fewer = lesions;
      fewer.pop_back();
      if (part < 1) expect_miss(object, params, fewer, "the number of lesions");
      for (const int other : {-1, 0, 1}) {
        if (other != part) {
          EXPECT_NE(part_cache_key(object, params, lesions, other), base);
        }
      }

      // The mesh is known by its content: the same bytes under another name are the same part.
      ObjectDesc renamed = object;
      renamed.shape.file = same;
      EXPECT_EQ(part_cache_key(renamed, params, lesions, part), base) << kind_name(kind);
    }
  }
  // Every leaf was visited: 8 molar, 6 premolar, 4 gingiva, 4 tongue fields, kind, file, scale, size.
  EXPECT_EQ(leaf_count(object.shape), 4u + 8u + 6u + 4u + 4u);
  EXPECT_EQ(leaf_count(TreeDesc{}), 9u);
  EXPECT_EQ(leaf_count(LesionShape{}), 8u);
  EXPECT_GT(misses, 600u);
}

TEST_F(CacheKeyTest, MirroredTeethThroughOneCacheAreBuiltMirrored) {
  // A molar and a premolar, unmirrored, then mirrored, through one cache: the mirrored build misses
  // the cache and gives the tree a build without the cache gives (the key once ignored `mirrored`:
  // 1404 leaves came back from the cache where 1368 were built).
  for (const char* type : {"molar", "premolar"}) {
    const auto scene = [&](bool mirrored) {
      return parse_scene(std::string("objects:\n  - name: tooth\n    shape: {type: ") + type +
                             ", resolution: 0.3, mirrored: " + (mirrored ? "true" : "false") +
                             "}\n    tree: {tolerance: 0.05, max_radius: 0.8}\n",
                         std::string(type) + ".yaml");
    };
    BuildOptions cached;
    cached.cache_dir = dir_ / "cache";
    BuildReport first, second, again;
    const Model right = build_model(scene(false), cached, &first);
    const Model left = build_model(scene(true), cached, &second);
    (void)build_model(scene(true), cached, &again);
    BuildOptions uncached;
    uncached.use_cache = false;
    const Model fresh = build_model(scene(true), uncached);

    ASSERT_EQ(first.parts.size(), 1u);
    ASSERT_EQ(second.parts.size(), 1u);
    EXPECT_FALSE(first.parts[0].cache_hit) << type;
    EXPECT_FALSE(second.parts[0].cache_hit) << type << ": mirrored: true came from the unmirrored entry";
    EXPECT_TRUE(again.parts[0].cache_hit) << type;
    const SphereTree& a = left.objects[0].tree;
    const SphereTree& b = fresh.objects[0].tree;
    ASSERT_EQ(a.leaf_count(), b.leaf_count()) << type;
    for (std::size_t i = 0; i < a.nodes.size(); ++i) {
      ASSERT_EQ(a.nodes[i].center, b.nodes[i].center) << type << " node " << i;
      ASSERT_EQ(a.nodes[i].radius, b.nodes[i].radius) << type << " node " << i;
    }
    // And the two sides differ, so an unmirrored tree from the cache would have been caught.
    const SphereTree& r = right.objects[0].tree;
    bool differ = r.nodes.size() != a.nodes.size();
    for (std::size_t i = 0; !differ && i < a.nodes.size(); ++i)
      differ = r.nodes[i].center != a.nodes[i].center;
    EXPECT_TRUE(differ) << type;
  }
}

}  // namespace
}  // namespace cariesim
