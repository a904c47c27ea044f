#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "cariesim/collision/collide.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// A 6 x 6 x 4 mm block (top face at z = 0) with a disk lesion on top; `extra` is appended.
std::string block_scene(const std::string& lesion_placement, const std::string& extra = "") {
  return R"(objects:
  - name: block
    shape: {type: cuboid, size: [6, 6, 4]}
    pose: {position: [1, 2, 3]}
    tissue: enamel
    enamel_thickness: 0.6
    tree: {tolerance: 0.05, max_radius: 0.8}
lesions:
  - name: pit
    object: block
    placement: )" +
         lesion_placement + R"(
    shape: {type: disk, size: 2.0, depth: 1.0}
    severity: severe
    material: {anisotropic: {direction: [1, 0, 0], mu_s: 0.9, mu_d: 0.8}}
)" + extra;
}

// A cache folder per test, removed afterwards.
class BuildTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    cache_ = fs::temp_directory_path() /
             ("cariesim_build_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(cache_);
  }
  void TearDown() override { fs::remove_all(cache_); }
  BuildOptions options() const {
    BuildOptions o;
    o.cache_dir = cache_;
    return o;
  }
  fs::path cache_;
};

// Smallest gap (mm) between a point and the union of a tree's leaves.
double gap_to_leaves(const SphereTree& tree, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const uint32_t n : tree.leaf_nodes) {
    best = std::min(best, (tree.nodes[n].center.cast<double>() - p).norm() - tree.nodes[n].radius);
  }
  return best;
}

TEST_F(BuildTest, BlockWithALesionMakesTwoPartsWithTheirMaterials) {
  const SceneDesc scene =
      parse_scene(block_scene("{at: [0, 0, 0.7], normal: [0, 0, 1], snap_range: 2}"), "b.yaml");
  BuildReport report;
  const Model model = build_model(scene, options(), &report);

  // Parts: healthy block, caries of the lesion.
  ASSERT_EQ(model.objects.size(), 2u);
  EXPECT_EQ(model.objects[0].name, "block/healthy");
  EXPECT_EQ(model.objects[1].name, "block/pit");
  EXPECT_EQ(model.objects[0].lesion, -1);
  EXPECT_EQ(model.objects[1].lesion, 0);
  EXPECT_EQ(model.objects[1].host, 0);
  EXPECT_EQ(model.objects[1].scene_object, 0);
  ASSERT_EQ(report.parts.size(), 2u);
  EXPECT_FALSE(report.parts[0].cache_hit);
  EXPECT_EQ(report.parts[1].leaves, model.objects[1].tree.leaf_count());

  // The lesion: snapped onto the top face (world z = 3), its material and severity.
  ASSERT_EQ(model.lesions.size(), 1u);
  const LesionModel& lesion = model.lesions[0];
  EXPECT_EQ(lesion.object, 1);
  EXPECT_EQ(lesion.host, 0);
  EXPECT_EQ(lesion.severity, "severe");
  EXPECT_DOUBLE_EQ(lesion.authored_depth, 1.0);
  EXPECT_NEAR(lesion.shape.center.z(), 3.0, 1e-6);
  EXPECT_NEAR(lesion.shape.center.x(), 1.0, 1e-9);
  const Material& caries = model.defaults.materials.at(lesion.material);
  EXPECT_EQ(caries.tissue, Tissue::Caries);
  EXPECT_EQ(caries.lesion, 0);
  EXPECT_DOUBLE_EQ(caries.mu_s, caries_preset(CariesPreset::Severe).mu_s);

  // Every caries leaf carries the lesion's material; healthy leaves are enamel or (deeper) dentin.
  for (const uint32_t n : model.objects[1].tree.leaf_nodes) {
    ASSERT_EQ(model.objects[1].tree.nodes[n].material, lesion.material);
  }
  int enamel = 0;
  int dentin = 0;
  const SphereTree& healthy = model.objects[0].tree;
  for (std::size_t i = 0; i < healthy.leaf_nodes.size(); ++i) {
    const Material& m = model.defaults.materials.at(healthy.nodes[healthy.leaf_nodes[i]].material);
    ASSERT_TRUE(m.tissue == Tissue::Enamel || m.tissue == Tissue::Dentin);
    EXPECT_TRUE(m.rigid());
    (m.tissue == Tissue::Enamel ? enamel : dentin)++;
    if (m.tissue == Tissue::Dentin) {
      EXPECT_GT(healthy.leaf_depth[i], 0.6f);
    }
  }
  EXPECT_GT(enamel, 0);
  EXPECT_GT(dentin, 0);

  // A point inside the lesion and the block lies in a caries leaf, not a healthy one.
  const Vec3 inside(1.0, 2.0, 2.6);
  EXPECT_LE(gap_to_leaves(model.objects[1].tree, inside), 0.0);
  EXPECT_GT(gap_to_leaves(model.objects[0].tree, inside), 0.0);

  // Display parts: the two cut parts, the healthy one carrying the block whole (drawn while the lesion
  // is hidden, so that no seam between the parts outlines it); the tool and its free home pose.
  ASSERT_EQ(model.display.size(), 2u);
  EXPECT_EQ(model.display[1].lesion, 0);
  EXPECT_EQ(model.display[1].tissue, Tissue::Caries);
  EXPECT_FALSE(model.display[0].mesh.triangles.empty());
  EXPECT_TRUE(model.display[0].cut && model.display[1].cut);
  EXPECT_EQ(model.display[0].whole.triangles.size(), make_cuboid(Vec3(6, 6, 4)).triangles.size())
      << "the healthy part carries the uncut block";
  EXPECT_TRUE(model.display[1].whole.triangles.empty());
  EXPECT_FALSE(model.tool.tree.empty());
  EXPECT_FALSE(model.tool.display.triangles.empty());
  EXPECT_GT(model.tool_home.p.z(), 3.0);  // the default home: above the block, tip lowest
  for (const uint32_t n : model.tool.tree.leaf_nodes) {
    ASSERT_GE(model.tool_home.transform(model.tool.tree.nodes[n].center.cast<double>()).z(),
              model.tool_home.p.z() - 1e-3);
  }
  PlacedTool placed(model.tool.tree);
  placed.place(model.tool_home, 0.0);
  EXPECT_GE(closest(placed, model.objects, kAllObjects, 1.0).gap, 0.0);
}

// Field by field: two materials are the same (the scene's and the model's).
void expect_same_material(const Material& a, const Material& b, const std::string& what) {
  EXPECT_EQ(a.tissue, b.tissue) << what;
  EXPECT_EQ(a.stiffness, b.stiffness) << what;
  EXPECT_EQ(a.mu_s, b.mu_s) << what;
  EXPECT_EQ(a.mu_d, b.mu_d) << what;
  EXPECT_EQ(a.aniso_dir, b.aniso_dir) << what;
  EXPECT_EQ(a.mu_s_along, b.mu_s_along) << what;
  EXPECT_EQ(a.mu_d_along, b.mu_d_along) << what;
  EXPECT_EQ(a.k_e, b.k_e) << what;
  EXPECT_EQ(a.k_c.kind, b.k_c.kind) << what;
  EXPECT_EQ(a.k_c.values, b.k_c.values) << what;
  EXPECT_EQ(a.k_c.bounds, b.k_c.bounds) << what;
  EXPECT_EQ(a.k_c.layer_count, b.k_c.layer_count) << what;
  EXPECT_EQ(a.crush_length, b.crush_length) << what;
  EXPECT_EQ(a.f_p_star, b.f_p_star) << what;
  EXPECT_EQ(a.f_e_star, b.f_e_star) << what;
  EXPECT_EQ(a.k_theta, b.k_theta) << what;
}

TEST_F(BuildTest, ObjectsAndLesionsCarryTheScenesMaterialsAndOneRuleSaysWhatIsRigid) {
  // A rigid block with a lesion and a soft pad: healthy tissue and lesions hold one Material type in
  // the scene description, and the model's table holds those materials as they are (the lesion's
  // with its index). Which objects are met only at their surface is the step's rigid rule.
  const SceneDesc scene = parse_scene(R"(objects:
  - name: block
    shape: {type: cuboid, size: [6, 6, 4]}
    tissue: enamel
    material: {mu_s: 0.2, mu_d: 0.1}
    tree: {tolerance: 0.05, max_radius: 0.8}
  - name: pad
    shape: {type: cuboid, size: [4, 4, 2]}
    pose: {position: [20, 0, 0]}
    tissue: gingiva
    material: {stiffness: 0.4, mu_s: 0.3, mu_d: 0.25}
    tree: {tolerance: 0.05, max_radius: 0.8}
lesions:
  - name: pit
    object: block
    placement: {at: [0, 0, 0], normal: [0, 0, 1]}
    shape: {type: disk, size: 2.0, depth: 1.0}
    severity: mild
)",
                                      "m.yaml");
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_EQ(scene.objects[1].material.tissue, Tissue::Gingiva);
  EXPECT_EQ(scene.objects[1].material.stiffness, 0.4);
  const Model model = build_model(scene, options());
  ASSERT_EQ(model.objects.size(), 3u);  // block/healthy, block/pit, pad

  // Each part's leaves: the scene's material of its object or lesion.
  const std::vector<Material>& table = model.defaults.materials;
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    const CollisionObject& o = model.objects[i];
    Material expected = o.lesion >= 0 ? scene.lesions[static_cast<std::size_t>(o.lesion)].material
                                      : scene.objects[static_cast<std::size_t>(o.scene_object)].material;
    expected.lesion = o.lesion;
    for (const uint32_t n : o.tree.leaf_nodes)
      expect_same_material(table.at(o.tree.nodes[n].material), expected, o.name);
  }

  // One rule: surface_only is rigid_object, the mask the step and the experiments use.
  const ObjectMask rigid = rigid_objects(model);
  EXPECT_EQ(rigid, ObjectMask{0b001}) << "only the healthy block is rigid";
  for (std::size_t i = 0; i < model.objects.size(); ++i)
    EXPECT_EQ(model.objects[i].surface_only, ((rigid >> i) & 1u) != 0) << model.objects[i].name;
}

TEST_F(BuildTest, ObjectFrameAnisotropyIsRotatedIntoTheWorld) {
  std::string yaml = block_scene("{at: [0, 0, 0], normal: [0, 0, 1]}");
  yaml.replace(yaml.find("pose: {position: [1, 2, 3]}"), 27,
               "pose: {position: [1, 2, 3], rotation: {axis: [0, 0, 1], angle: 90}}");
  const Model model = build_model(parse_scene(yaml, "b.yaml"), options());
  const Material& m = model.defaults.materials.at(model.lesions.at(0).material);
  EXPECT_TRUE(m.aniso_dir.isApprox(Vec3::UnitY(), 1e-12));
}

TEST_F(BuildTest, CacheHitGivesTheSameTrees) {
  const SceneDesc scene = parse_scene(block_scene("{at: [0, 0, 0], normal: [0, 0, 1]}"), "b.yaml");
  BuildReport cold;
  const Model first = build_model(scene, options(), &cold);
  BuildReport hit;
  const Model second = build_model(scene, options(), &hit);
  ASSERT_EQ(hit.parts.size(), cold.parts.size());
  for (std::size_t i = 0; i < hit.parts.size(); ++i) {
    EXPECT_FALSE(cold.parts[i].cache_hit);
    EXPECT_TRUE(hit.parts[i].cache_hit);
    const SphereTree& a = first.objects[i].tree;
    const SphereTree& b = second.objects[i].tree;
    ASSERT_EQ(a.nodes.size(), b.nodes.size());
    for (std::size_t n = 0; n < a.nodes.size(); ++n) {
      ASSERT_EQ(a.nodes[n].center, b.nodes[n].center);
      ASSERT_EQ(a.nodes[n].radius, b.nodes[n].radius);
      ASSERT_EQ(a.nodes[n].material, b.nodes[n].material);
    }
  }
  EXPECT_EQ(first.scene_hash, second.scene_hash);

  // Any change to a lesion misses the cache for that object's parts.
  const SceneDesc moved = parse_scene(block_scene("{at: [0.5, 0, 0], normal: [0, 0, 1]}"), "b.yaml");
  BuildReport changed;
  const Model third = build_model(moved, options(), &changed);
  EXPECT_FALSE(changed.parts[0].cache_hit);
  EXPECT_FALSE(changed.parts[1].cache_hit);
  EXPECT_NE(third.scene_hash, first.scene_hash);

  // Without the cache nothing is read.
  BuildOptions no_cache = options();
  no_cache.use_cache = false;
  BuildReport uncached;
  (void)build_model(scene, no_cache, &uncached);
  EXPECT_FALSE(uncached.parts[0].cache_hit);
}

// Trainee mode (BuildOptions::cache_lesion_parts false) leaves no part of an object that carries a
// lesion in the tree cache (its healthy part is the tooth minus the lesion, its caries part the
// lesion): only the lesion-free object's tree is stored, and a second build misses on exactly those
// parts. Before, every part went into the cache, readable at the station.
TEST_F(BuildTest, TraineeBuildsStoreNoPartOfAnObjectWithLesions) {
  std::string text = block_scene("{at: [0, 0, 0], normal: [0, 0, 1]}");
  text.insert(
      text.find("lesions:"),
      "  - name: plain\n    shape: {type: cuboid, size: [2, 2, 2]}\n    pose: {position: [20, 0, 0]}\n"
      "    tissue: enamel\n    tree: {tolerance: 0.1, max_radius: 0.8}\n");
  const SceneDesc scene = parse_scene(text, "b.yaml");
  const auto entries = [this] {
    std::size_t n = 0;
    for (const auto& entry : fs::directory_iterator(cache_)) n += entry.path().extension() == ".tree" ? 1 : 0;
    return n;
  };
  BuildOptions trainee = options();
  trainee.cache_lesion_parts = false;
  BuildReport first;
  const Model model = build_model(scene, trainee, &first);
  ASSERT_EQ(model.objects.size(), 3u);
  EXPECT_EQ(model.objects[2].name, "plain");
  EXPECT_EQ(entries(), 1u) << "only the lesion-free object's tree";
  BuildReport second;
  (void)build_model(scene, trainee, &second);
  ASSERT_EQ(second.parts.size(), 3u);
  EXPECT_FALSE(second.parts[0].cache_hit) << second.parts[0].name;
  EXPECT_FALSE(second.parts[1].cache_hit) << second.parts[1].name;
  EXPECT_TRUE(second.parts[2].cache_hit) << second.parts[2].name;
  // The default stores every part.
  (void)build_model(scene, options());
  EXPECT_EQ(entries(), 3u);
}

TEST_F(BuildTest, DeviationIsMeasuredOnRequest) {
  BuildOptions o = options();
  o.measure_deviation = true;
  o.deviation_samples = 20000;
  BuildReport report;
  (void)build_model(parse_scene(block_scene("{at: [0, 0, 0], normal: [0, 0, 1]}"), "b.yaml"), o, &report);
  for (const PartReport& part : report.parts) {
    ASSERT_TRUE(part.deviation.has_value()) << part.name;
    EXPECT_GE(part.deviation->samples, 20000u);
    EXPECT_LE(part.deviation->p50, part.deviation->p95);
    EXPECT_LE(part.deviation->p95, part.deviation->max);
    EXPECT_TRUE(std::isfinite(part.deviation->max));
  }
}

TEST_F(BuildTest, ALesionThatMissesItsObjectIsAnError) {
  const SceneDesc scene =
      parse_scene(block_scene("{at: [30, 0, 0], normal: [0, 0, 1], snap: false}"), "miss.yaml");
  try {
    (void)build_model(scene, options());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("miss.yaml:9:5: lesion 'pit'"));
    EXPECT_THAT(e.what(), HasSubstr("does not overlap 'block'"));
  }
}

TEST_F(BuildTest, SnappingWithNoSurfaceInRangeIsAnError) {
  const SceneDesc scene =
      parse_scene(block_scene("{at: [0, 0, 9], normal: [0, 0, 1], snap_range: 2}"), "far.yaml");
  try {
    (void)build_model(scene, options());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("far.yaml:9:5: lesion 'pit'"));
    EXPECT_THAT(e.what(), HasSubstr("snap_range 2 mm"));
  }
}

TEST_F(BuildTest, AToolHomeInsideAnObjectIsAnError) {
  const SceneDesc scene = parse_scene(
      block_scene("{at: [0, 0, 0], normal: [0, 0, 1]}", "tool: {home: {position: [1, 2, 1]}}\n"), "h.yaml");
  try {
    (void)build_model(scene, options());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("tool.home"));
  }
}

TEST_F(BuildTest, CommandLineOverridesChangeTheTrees) {
  const SceneDesc scene = parse_scene(block_scene("{at: [0, 0, 0], normal: [0, 0, 1]}"), "b.yaml");
  BuildOptions o = options();
  o.mode = TreeMode::Octree;
  o.octree_depth = 2;
  const Model model = build_model(scene, o);
  for (const CollisionObject& object : model.objects) {
    EXPECT_EQ(object.tree.mode, TreeMode::Octree);
    EXPECT_LE(object.tree.leaf_count(), 64u);  // 8^2
  }
}

TEST(MeshScene, WrapsAMeshFile) {
  EXPECT_THROW((void)mesh_scene("/no/such/file.stl"), Error);
  const fs::path file =
      fs::temp_directory_path() / ("cariesim_mesh_scene_" + std::to_string(::getpid()) + ".stl");
  std::ofstream(file) << "solid x\nendsolid x\n";
  const SceneDesc s = mesh_scene(file);
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].shape.kind, ShapeDesc::Kind::Mesh);
  EXPECT_EQ(s.objects[0].shape.file, file);
  EXPECT_EQ(s.objects[0].kind, ObjectKind::Rigid);
  fs::remove(file);
}

}  // namespace
}  // namespace cariesim
