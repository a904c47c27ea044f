// Builds the built-in oral cavity (no files needed) and the real-scan example scene. Trees are cached
// in the build folder, so only the first run pays for building them.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <string>

#include "cariesim/collision/collide.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

namespace fs = std::filesystem;

BuildOptions test_options() {
  BuildOptions o;
  o.cache_dir = fs::path(CARIESIM_BINARY_DIR) / "test-cache";
  return o;
}

// Smallest gap (mm) between a point and the union of a tree's leaves.
double gap_to_leaves(const SphereTree& tree, const Vec3& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const uint32_t n : tree.leaf_nodes) {
    best = std::min(best, (tree.nodes[n].center.cast<double>() - p).norm() - tree.nodes[n].radius);
  }
  return best;
}

// Index of the collision object of that name.
int object_named(const Model& model, const std::string& name) {
  for (std::size_t i = 0; i < model.objects.size(); ++i) {
    if (model.objects[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

// Smallest gap (mm) between the leaves of two objects (branch and bound through the collision query).
double gap_between(const Model& model, int a, int b) {
  PlacedTool placed(model.objects[static_cast<std::size_t>(a)].tree);
  placed.place(Pose{}, 0.0);
  return closest(placed, model.objects, ObjectMask{1} << b, 10.0).gap;
}

class OralCavity : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { model_ = new Model(build_model(load_scene("oral-cavity"), test_options())); }
  static void TearDownTestSuite() {
    delete model_;
    model_ = nullptr;
  }
  static Model* model_;
};
Model* OralCavity::model_ = nullptr;

TEST_F(OralCavity, BuildsEveryPartWithNoFiles) {
  const Model& m = *model_;
  EXPECT_EQ(m.objects.size(), 12u);  // 6 teeth, 2 gingiva bands, tongue, 3 caries parts
  EXPECT_EQ(m.display.size(), m.objects.size());
  for (const CollisionObject& o : m.objects) {
    EXPECT_FALSE(o.tree.empty()) << o.name;
    EXPECT_EQ(check_tree(o.tree, 1e-3), "") << o.name;
  }
  EXPECT_EQ(m.objects[static_cast<std::size_t>(object_named(m, "tongue"))].kind, ObjectKind::Soft);
  EXPECT_EQ(m.objects[static_cast<std::size_t>(object_named(m, "gingiva-left"))].kind, ObjectKind::Soft);
  EXPECT_EQ(m.objects[static_cast<std::size_t>(object_named(m, "tooth45"))].kind, ObjectKind::Rigid);
  PlacedTool tool(m.tool.tree);
  tool.place(m.tool_home, 0.0);
  EXPECT_GE(closest(tool, m.objects, kAllObjects, 5.0).gap, 0.0);
}

TEST_F(OralCavity, LesionsSitOnTheirTeeth) {
  const Model& m = *model_;
  ASSERT_EQ(m.lesions.size(), 3u);
  const int healthy46 = object_named(m, "tooth46/healthy");
  const int healthy36 = object_named(m, "tooth36/healthy");
  ASSERT_GE(healthy46, 0);
  ASSERT_GE(healthy36, 0);
  EXPECT_EQ(m.lesions[0].host, healthy46);
  EXPECT_EQ(m.lesions[1].host, healthy46);
  EXPECT_EQ(m.lesions[2].host, healthy36);
  for (const LesionModel& l : m.lesions) {
    const CollisionObject& caries = m.objects[static_cast<std::size_t>(l.object)];
    EXPECT_EQ(caries.lesion, &l - m.lesions.data());
    EXPECT_GT(caries.tree.leaf_count(), 10u) << l.name;
    // The caries reaches about the authored depth below the surface, not beyond.
    const float deepest = *std::max_element(caries.tree.leaf_depth.begin(), caries.tree.leaf_depth.end());
    EXPECT_GT(deepest, 0.3 * l.authored_depth) << l.name;
    EXPECT_LT(deepest, l.authored_depth + 0.1) << l.name;
    // Every caries leaf carries the lesion's material.
    for (const uint32_t n : caries.tree.leaf_nodes) ASSERT_EQ(caries.tree.nodes[n].material, l.material);
  }
  // The occlusal lesions lie in the crown, below the authored point (snapped into the fossa).
  for (const LesionModel* l : {&m.lesions[0], &m.lesions[2]}) {
    EXPECT_GT(l->shape.center.z(), 4.0) << l->name;
    EXPECT_LE(l->shape.center.z(), 7.0 + 1e-9) << l->name;
  }
}

// Lower molars have their lingual cusps higher: the highest point of every molar faces the tongue,
// which the right-side teeth only do when mirrored (scenes/oral-cavity.yaml).
TEST_F(OralCavity, LingualCuspsFaceTheTongue) {
  const Model& m = *model_;
  for (const char* name : {"tooth46/healthy", "tooth47", "tooth36/healthy", "tooth37"}) {
    const DisplayPart& part = m.display[static_cast<std::size_t>(object_named(m, name))];
    Vec3f top = part.mesh.vertices.front();
    for (const Vec3f& v : part.mesh.vertices) {
      if (v.z() > top.z()) top = v;
    }
    const double centre_x = part.mesh.bounds().center().x();
    EXPECT_LT(std::abs(top.x()), std::abs(centre_x)) << name << ": its highest cusp is buccal";
  }
}

// Lesion #2 faces 45 across a gap a correctly angled explorer fits through (paper Fig. 17b).
TEST_F(OralCavity, InterproximalGapIsProbeSized) {
  const Model& m = *model_;
  const int tooth45 = object_named(m, "tooth45");
  ASSERT_GE(tooth45, 0);
  const double gap =
      gap_to_leaves(m.objects[static_cast<std::size_t>(tooth45)].tree, m.lesions[1].shape.center);
  EXPECT_GT(gap, 1.3);
  EXPECT_LT(gap, 3.0);  // on the marginal ridge slope, above the contact area
  // The neighbouring teeth, and the tongue and the teeth, do not touch.
  EXPECT_GT(gap_between(m, object_named(m, "tooth46/healthy"), tooth45), 0.3);
  EXPECT_GT(gap_between(m, object_named(m, "tooth36/healthy"), object_named(m, "tooth35")), 0.1);
  for (const char* tooth :
       {"tooth46/healthy", "tooth45", "tooth47", "tooth36/healthy", "tooth35", "tooth37"}) {
    EXPECT_GT(gap_between(m, object_named(m, "tongue"), object_named(m, tooth)), 0.5) << tooth;
  }
}

// The real arch (issue #12), built once per test program from the shipped scans (cached in the
// build folder's test cache, which EveryBuiltInBuilds shares).
class RealArch : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { model_ = new Model(build_model(load_scene("real-arch"), test_options())); }
  static void TearDownTestSuite() {
    delete model_;
    model_ = nullptr;
  }
  static const CollisionObject& object(const std::string& name) {
    const int i = object_named(*model_, name);
    EXPECT_GE(i, 0) << name;
    return model_->objects[static_cast<std::size_t>(std::max(i, 0))];
  }
  static Model* model_;
};
Model* RealArch::model_ = nullptr;

TEST_F(RealArch, BuildsEveryToothGumsAndTongue) {
  const Model& m = *model_;
  EXPECT_EQ(m.objects.size(), 21u);  // 16 teeth, gingiva, tongue, 3 caries parts
  for (const CollisionObject& o : m.objects) {
    EXPECT_GT(o.tree.leaf_count(), 100u) << o.name;
    EXPECT_EQ(check_tree(o.tree, 1e-3), "") << o.name;
  }
  EXPECT_EQ(object("gingiva").kind, ObjectKind::Soft);
  EXPECT_EQ(object("tongue").kind, ObjectKind::Soft);
  PlacedTool tool(m.tool.tree);
  tool.place(m.tool_home, 0.0);
  EXPECT_GE(closest(tool, m.objects, kAllObjects, 5.0).gap, 0.0);

  // Every crown stands clear of the gums and every root apex is inside them; the tongue touches no
  // tooth.
  const SphereTree& gums = object("gingiva").tree;
  for (const CollisionObject& o : m.objects) {
    if (o.name.rfind("tooth", 0) != 0 || o.lesion >= 0) continue;
    Vec3 top(0, 0, -1e9);
    Vec3 apex(0, 0, 1e9);
    for (const uint32_t n : o.tree.leaf_nodes) {
      const Vec3 c = o.tree.nodes[n].center.cast<double>();
      if (c.z() > top.z()) top = c;
      if (c.z() < apex.z()) apex = c;
    }
    EXPECT_GT(gap_to_leaves(gums, top), 3.0) << o.name << ": the crown is exposed";
    EXPECT_LT(gap_to_leaves(gums, apex), 0.0) << o.name << ": the root is covered";
    EXPECT_GT(gap_between(m, object_named(m, "tongue"), object_named(m, o.name)), 0.5) << o.name;
  }
}

TEST_F(RealArch, LesionsSitOnTheirTeeth) {
  const Model& m = *model_;
  ASSERT_EQ(m.lesions.size(), 3u);
  EXPECT_EQ(m.lesions[0].host, object_named(m, "tooth46/healthy"));
  EXPECT_EQ(m.lesions[1].host, object_named(m, "tooth46/healthy"));
  EXPECT_EQ(m.lesions[2].host, object_named(m, "tooth36/healthy"));
  for (const LesionModel& l : m.lesions) {
    const CollisionObject& caries = m.objects[static_cast<std::size_t>(l.object)];
    EXPECT_GT(caries.tree.leaf_count(), 10u) << l.name;
    const float deepest = *std::max_element(caries.tree.leaf_depth.begin(), caries.tree.leaf_depth.end());
    EXPECT_GT(deepest, 0.3 * l.authored_depth) << l.name;
    EXPECT_LT(deepest, l.authored_depth + 0.1) << l.name;
  }
  // The occlusal lesions were snapped onto their crowns, in the top 3 mm of the tooth.
  for (const auto& [lesion, tooth] : {std::pair{0, "tooth46/healthy"}, std::pair{2, "tooth36/healthy"}}) {
    double top = -1e9;
    const SphereTree& t = object(tooth).tree;
    for (const uint32_t n : t.leaf_nodes) top = std::max(top, static_cast<double>(t.nodes[n].center.z()));
    EXPECT_GT(m.lesions[static_cast<std::size_t>(lesion)].shape.center.z(), top - 3.0) << tooth;
  }
}

// Lesion #2 sits on 46's mesial surface under the contact with 45: 45 is just in front of it, and
// an explorer tip reaches it from the buccal or the lingual embrasure but not straight from above.
TEST_F(RealArch, InterproximalLesionFacesTheContactWith45) {
  const Model& m = *model_;
  const LesionShape& l = m.lesions[1].shape;
  const SphereTree& t45 = object("tooth45").tree;
  const SphereTree& t46 = object("tooth46/healthy").tree;
  const double gap45 = gap_to_leaves(t45, l.center);
  EXPECT_GT(gap45, 0.2);
  EXPECT_LT(gap45, 1.5);
  // 45's nearest leaf lies ahead of the lesion's normal.
  double best = std::numeric_limits<double>::infinity();
  Vec3 nearest = Vec3::Zero();
  for (const uint32_t n : t45.leaf_nodes) {
    const double d = (t45.nodes[n].center.cast<double>() - l.center).norm() - t45.nodes[n].radius;
    if (d < best) best = d, nearest = t45.nodes[n].center.cast<double>();
  }
  EXPECT_GT((nearest - l.center).normalized().dot(l.normal), 0.5);

  // The tip (0.05 mm) 0.3 mm off the lesion, moved up, runs into a crown: hidden from occlusal.
  const Vec3 start = l.center + 0.3 * l.normal;
  auto clear = [&](const Vec3& p) { return std::min(gap_to_leaves(t45, p), gap_to_leaves(t46, p)) > 0.05; };
  bool blocked_above = false;
  for (double k = 0.25; k <= 8.0; k += 0.25) blocked_above |= !clear(start + k * Vec3::UnitZ());
  EXPECT_TRUE(blocked_above) << "the lesion is visible straight from above";
  // Moved out along the surface, bucco-lingually, it comes free on one side at least.
  const Vec3 across = (l.tangent - l.tangent.dot(l.normal) * l.normal).normalized();
  bool open_side = false;
  for (const double side : {1.0, -1.0}) {
    bool free = true;
    for (double k = 0.0; k <= 8.0; k += 0.25) free &= clear(start + side * k * across);
    open_side |= free;
  }
  EXPECT_TRUE(open_side) << "no embrasure leads to the lesion";
}

// Every built-in scene builds: trees for every part, a lesion part per lesion, a free home pose.
TEST(BuiltinScenesBuild, EveryBuiltInBuilds) {
  for (const auto& name : builtin_scene_names()) {
    SCOPED_TRACE(name);
    const SceneDesc scene = load_scene(name);
    const Model model = build_model(scene, test_options());
    EXPECT_EQ(model.objects.size(), scene.objects.size() + scene.lesions.size());
    EXPECT_EQ(model.lesions.size(), scene.lesions.size());
    for (const CollisionObject& o : model.objects) EXPECT_GT(o.tree.leaf_count(), 0u) << o.name;
    PlacedTool tool(model.tool.tree);
    tool.place(model.tool_home, 0.0);
    EXPECT_GE(closest(tool, model.objects, kAllObjects, 1.0).gap, 0.0);
    // The tip is the tool's lowest point at home.
    double lowest = std::numeric_limits<double>::infinity();
    for (const uint32_t n : model.tool.tree.leaf_nodes) {
      lowest =
          std::min(lowest, model.tool_home.transform(model.tool.tree.nodes[n].center.cast<double>()).z());
    }
    EXPECT_NEAR(lowest, model.tool_home.p.z(), 1e-3);
  }
}

// scenes/examples/real-tooth.yaml: a real scan by a path relative to the scene file, with a lesion.
TEST(ExampleScenes, RealToothScanBuilds) {
  const fs::path data = fs::path(CARIESIM_DATA_DIR) / "open-full-jaw" / "patient26" / "tooth_30.ply";
  if (!fs::exists(data)) GTEST_SKIP() << "shipped scan missing: " << data;
  const SceneDesc scene =
      load_scene((fs::path(CARIESIM_SOURCE_DIR) / "scenes" / "examples" / "real-tooth.yaml").string());
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(fs::weakly_canonical(scene.objects[0].shape.file), fs::weakly_canonical(data));

  BuildReport report;
  const Model model = build_model(scene, test_options(), &report);
  ASSERT_EQ(model.objects.size(), 2u);
  EXPECT_EQ(model.objects[1].lesion, 0);
  EXPECT_GT(model.objects[0].tree.leaf_count(), 1000u);
  EXPECT_GT(model.objects[1].tree.leaf_count(), 10u);
  // The lesion was snapped onto the crown's top.
  EXPECT_GT(model.lesions[0].shape.center.z(), 58.0);
  EXPECT_LT(model.lesions[0].shape.center.z(), 63.0);
}

}  // namespace
}  // namespace cariesim
