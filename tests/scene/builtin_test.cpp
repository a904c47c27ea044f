#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"
#include "support/files.hpp"

namespace cariesim {
namespace {

using cariesim::test::read_text;

const std::filesystem::path kScenes = std::filesystem::path(CARIESIM_SOURCE_DIR) / "scenes";

TEST(BuiltinScenes, DefaultFirstAndAllPresent) {
  const auto names = builtin_scene_names();
  ASSERT_FALSE(names.empty());
  EXPECT_EQ(names.front(), "real-arch");  // the default
  for (const char* expected : {"oral-cavity", "real-arch", "friction-block", "boundary-square",
                               "boundary-triangle", "boundary-circle", "insertion-blocks"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  EXPECT_TRUE(builtin_scene_yaml("no-such-scene").empty());
}

TEST(BuiltinScenes, EmbeddedCopiesMatchTheFilesAndParse) {
  for (const auto& name : builtin_scene_names()) {
    SCOPED_TRACE(name);
    const std::filesystem::path file = kScenes / (name + ".yaml");
    ASSERT_TRUE(std::filesystem::exists(file));
    EXPECT_EQ(builtin_scene_yaml(name), read_text(file));
    const SceneDesc scene = load_scene(name);
    EXPECT_EQ(scene.name, name);
    EXPECT_EQ(scene.origin, "builtin:" + name);
    EXPECT_FALSE(scene.objects.empty());
    EXPECT_TRUE(scene.tool_home.has_value());
  }
}

// The oral cavity of paper §5.3: teeth, lesions, layout.
TEST(BuiltinScenes, OralCavityFollowsThePaper) {
  const SceneDesc s = load_scene("oral-cavity");
  auto tooth = [&](int fdi) -> const ObjectDesc* {
    for (const auto& o : s.objects)
      if (o.fdi == fdi) return &o;
    return nullptr;
  };
  for (int fdi : {45, 46, 47, 35, 36, 37}) {
    ASSERT_NE(tooth(fdi), nullptr) << fdi;
    EXPECT_NE(tooth(fdi)->shape.kind, ShapeDesc::Kind::Mesh) << "procedural only";
    EXPECT_EQ(tooth(fdi)->tree.params.mode, TreeMode::Tight);
  }
  EXPECT_EQ(tooth(46)->shape.kind, ShapeDesc::Kind::Molar);
  EXPECT_EQ(tooth(36)->shape.kind, ShapeDesc::Kind::Molar);
  EXPECT_EQ(tooth(45)->shape.kind, ShapeDesc::Kind::Premolar);
  EXPECT_EQ(tooth(35)->shape.kind, ShapeDesc::Kind::Premolar);
  // First molars about 45 mm apart centre to centre, on either side of the midline.
  EXPECT_NEAR((tooth(46)->pose.p - tooth(36)->pose.p).norm(), 45.0, 2.0);
  EXPECT_LT(tooth(46)->pose.p.x(), 0.0);
  EXPECT_GT(tooth(36)->pose.p.x(), 0.0);

  int gingiva = 0;
  int tongue = 0;
  for (const auto& o : s.objects) {
    gingiva += o.material.tissue == Tissue::Gingiva;
    tongue += o.material.tissue == Tissue::Tongue;
    if (o.material.tissue == Tissue::Gingiva || o.material.tissue == Tissue::Tongue) {
      EXPECT_EQ(o.kind, ObjectKind::Soft) << o.name;
    }
  }
  EXPECT_GE(gingiva, 1);
  EXPECT_EQ(tongue, 1);
  // The tongue lies between the rows.
  const int t = s.find_object("tongue");
  ASSERT_GE(t, 0);
  EXPECT_GT(s.objects[static_cast<std::size_t>(t)].pose.p.x(), tooth(46)->pose.p.x());
  EXPECT_LT(s.objects[static_cast<std::size_t>(t)].pose.p.x(), tooth(36)->pose.p.x());

  // Lesions #1 and #2 on 46, #3 on 36; #1 and #3 of different severity; realistic sizes.
  ASSERT_EQ(s.lesions.size(), 3u);
  const int t46 = s.find_object(tooth(46)->name);
  const int t36 = s.find_object(tooth(36)->name);
  EXPECT_EQ(s.lesions[0].object, t46);
  EXPECT_EQ(s.lesions[1].object, t46);
  EXPECT_EQ(s.lesions[2].object, t36);
  EXPECT_NE(s.lesions[0].severity, s.lesions[2].severity);
  for (const auto& l : s.lesions) {
    EXPECT_FALSE(l.severity.empty()) << l.name;
    EXPECT_GE(l.shape.depth, 1.0) << l.name;
    EXPECT_LE(l.shape.depth, 3.0) << l.name;
  }
  for (const auto* l : {&s.lesions[0], &s.lesions[2]}) {
    EXPECT_GE(l->shape.size, 1.5) << l->name;
    EXPECT_LE(l->shape.size, 3.0) << l->name;
    EXPECT_GT(lesion_shape_in_world(s, *l).normal.z(), 0.99) << "occlusal: " << l->name;
  }
  // #2 faces 45 (its normal leans from 46 toward 45) on the marginal ridge's slope, 37-53 degrees
  // from vertical.
  const LesionShape l2 = lesion_shape_in_world(s, s.lesions[1]);
  const Vec3 toward_45 = (tooth(45)->pose.p - tooth(46)->pose.p).normalized();
  EXPECT_GT(l2.normal.dot(toward_45), 0.55);
  EXPECT_GT(l2.normal.z(), 0.6);
  EXPECT_LT(l2.normal.z(), 0.8);
}

TEST(BuiltinScenes, ExperimentBlocksFollowThePaper) {
  // §4.2.2: 100 x 100 x 20 mm cubes, 60 mm lesions, 1 N/mm both regions, mu_s 0.5, mu_d 0.3.
  for (const char* name : {"boundary-square", "boundary-triangle", "boundary-circle"}) {
    SCOPED_TRACE(name);
    const SceneDesc s = load_scene(name);
    ASSERT_EQ(s.objects.size(), 1u);
    EXPECT_EQ(s.objects[0].shape.size, Vec3(100, 100, 20));
    EXPECT_DOUBLE_EQ(s.objects[0].material.stiffness, 1.0);
    EXPECT_DOUBLE_EQ(s.objects[0].material.mu_s, 0.0);
    ASSERT_EQ(s.lesions.size(), 1u);
    const LesionDesc& l = s.lesions[0];
    EXPECT_DOUBLE_EQ(l.shape.size, 60.0);
    EXPECT_DOUBLE_EQ(l.material.stiffness, 1.0);
    EXPECT_DOUBLE_EQ(l.material.mu_s, 0.5);
    EXPECT_DOUBLE_EQ(l.material.mu_d, 0.3);
  }
  EXPECT_EQ(load_scene("boundary-circle").lesions[0].shape.kind, LesionShape::Kind::Disk);
  EXPECT_EQ(load_scene("boundary-square").lesions[0].shape.polygon.size(), 4u);
  EXPECT_EQ(load_scene("boundary-triangle").lesions[0].shape.polygon.size(), 3u);

  // §4.1.1: the block's top is caries with mu_s 0.5, mu_d 0.3.
  const SceneDesc f = load_scene("friction-block");
  ASSERT_EQ(f.lesions.size(), 1u);
  EXPECT_DOUBLE_EQ(f.lesions[0].material.mu_s, 0.5);
  EXPECT_DOUBLE_EQ(f.lesions[0].material.mu_d, 0.3);

  // §5.1: k_e 1, k_c 10, k_p 1 N/mm, F_p* 3 N; the healthy cube is rigid, beside the caries cube.
  const SceneDesc ins = load_scene("insertion-blocks");
  ASSERT_EQ(ins.objects.size(), 2u);
  ASSERT_EQ(ins.lesions.size(), 1u);
  const Material& m = ins.lesions[0].material;
  EXPECT_DOUBLE_EQ(m.k_e, 1.0);
  EXPECT_DOUBLE_EQ(m.k_c.at(0.0), 10.0);
  EXPECT_DOUBLE_EQ(m.f_p_star, 3.0);
  EXPECT_DOUBLE_EQ(ins.limits.max_stiffness, 1.0);
  const ObjectDesc& caries_cube = ins.objects[static_cast<std::size_t>(ins.lesions[0].object)];
  const ObjectDesc& healthy_cube = ins.objects[ins.lesions[0].object == 0 ? 1u : 0u];
  EXPECT_DOUBLE_EQ(healthy_cube.pose.p.z(), caries_cube.pose.p.z());
  EXPECT_GT(healthy_cube.pose.p.x(), caries_cube.pose.p.x());
  EXPECT_TRUE(std::isinf(healthy_cube.material.stiffness))
      << "the healthy cube must be rigid: the probe may not enter it (issue 4)";
}

// The real arch (issue #12): the sixteen shipped scans, one pose for all (their scanned positions),
// fine trees on 36, 46 and their neighbours, gingiva and tongue, the paper's three lesion sites.
TEST(BuiltinScenes, RealArchIsTheScannedArch) {
  const SceneDesc s = load_scene("real-arch");
  const std::filesystem::path scans = data_directory() / "open-full-jaw" / "patient26";
  auto tooth = [&](int fdi) -> const ObjectDesc* {
    for (const auto& o : s.objects)
      if (o.fdi == fdi) return &o;
    return nullptr;
  };
  int teeth = 0;
  for (int quadrant : {3, 4}) {
    for (int t = 1; t <= 8; ++t) {
      const int fdi = 10 * quadrant + t;
      const ObjectDesc* o = tooth(fdi);
      ASSERT_NE(o, nullptr) << fdi;
      ++teeth;
      // Universal number: 17 + (8 - t) on the left (quadrant 3), 24 + t on the right (quadrant 4).
      const int universal = quadrant == 3 ? 25 - t : 24 + t;
      EXPECT_EQ(o->shape.kind, ShapeDesc::Kind::Mesh) << fdi;
      EXPECT_EQ(o->shape.file, (scans / ("tooth_" + std::to_string(universal) + ".ply")).lexically_normal())
          << fdi;
      EXPECT_EQ(o->kind, ObjectKind::Rigid) << fdi;
      EXPECT_TRUE(o->pose.p.isApprox(tooth(46)->pose.p) && o->pose.q.isApprox(tooth(46)->pose.q))
          << fdi << ": every scan keeps its scanned position";
      const bool fine = t >= 4 && t <= 7;  // the posterior teeth, 34-37 and 44-47
      EXPECT_DOUBLE_EQ(o->tree.params.tolerance, fine ? 0.015 : 0.05) << fdi;
    }
  }
  EXPECT_EQ(teeth, 16);
  int gingiva = 0;
  int tongue = 0;
  for (const auto& o : s.objects) {
    gingiva += o.material.tissue == Tissue::Gingiva;
    tongue += o.material.tissue == Tissue::Tongue;
    if (o.material.tissue == Tissue::Gingiva) {
      EXPECT_EQ(o.shape.gingiva.path.size(), 16u) << "one point per tooth";
    }
    if (o.material.tissue == Tissue::Gingiva || o.material.tissue == Tissue::Tongue) {
      EXPECT_EQ(o.kind, ObjectKind::Soft) << o.name;
    }
  }
  EXPECT_EQ(gingiva, 1);
  EXPECT_EQ(tongue, 1);

  // Lesions #1 and #2 on 46, #3 on 36; #1 and #3 occlusal (along the tooth's long axis, within 25
  // degrees of world up); #2 faces 45 (mesial, toward the front of the mouth).
  ASSERT_EQ(s.lesions.size(), 3u);
  EXPECT_EQ(s.objects[static_cast<std::size_t>(s.lesions[0].object)].fdi, 46);
  EXPECT_EQ(s.objects[static_cast<std::size_t>(s.lesions[1].object)].fdi, 46);
  EXPECT_EQ(s.objects[static_cast<std::size_t>(s.lesions[2].object)].fdi, 36);
  EXPECT_NE(s.lesions[0].severity, s.lesions[2].severity);
  for (const auto* l : {&s.lesions[0], &s.lesions[2]}) {
    EXPECT_GT(lesion_shape_in_world(s, *l).normal.z(), std::cos(25.0 * std::numbers::pi / 180.0)) << l->name;
  }
  const LesionShape l2 = lesion_shape_in_world(s, s.lesions[1]);
  EXPECT_LT(std::abs(l2.normal.z()), 0.5) << "a proximal surface, not an occlusal one";
  EXPECT_LT(l2.normal.y(), -0.8) << "46's mesial surface faces the front of the mouth, toward 45";
  // The tool starts above 46.
  ASSERT_TRUE(s.tool_home.has_value());
  EXPECT_LT(s.tool_home->p.x(), -15.0);
  EXPECT_GT(s.tool_home->p.z(), 10.0);
}

// A built-in scene whose scans are missing says which file and which data folder, and stops.
TEST(BuiltinScenes, RealArchWithoutItsDataIsAClearError) {
  ASSERT_EQ(::setenv("CARIESIM_DATA_DIR", "/nonexistent/cariesim-data", 1), 0);
  try {
    (void)load_scene("real-arch");
    ADD_FAILURE() << "loaded without its scans";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("builtin:real-arch"));
    EXPECT_THAT(e.what(),
                ::testing::HasSubstr(
                    "mesh file not found: /nonexistent/cariesim-data/open-full-jaw/patient26/tooth_32.ply"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("CARIESIM_DATA_DIR"));
  }
  ASSERT_EQ(::unsetenv("CARIESIM_DATA_DIR"), 0);
}

// docs/scene-format.md shows scenes/examples/commented.yaml verbatim; it parses.
TEST(ExampleScenes, CommentedExampleIsInTheDocsAndParses) {
  const std::filesystem::path file = kScenes / "examples" / "commented.yaml";
  const std::string text = read_text(file);
  ASSERT_FALSE(text.empty());
  const std::string docs = read_text(std::filesystem::path(CARIESIM_SOURCE_DIR) / "docs" / "scene-format.md");
  EXPECT_NE(docs.find("```yaml\n" + text + "```"), std::string::npos)
      << "docs/scene-format.md must contain scenes/examples/commented.yaml verbatim in a yaml block";
  const SceneDesc s = load_scene(file.string());
  EXPECT_EQ(s.name, "commented-example");
  EXPECT_EQ(s.objects.size(), 4u);
  EXPECT_EQ(s.lesions.size(), 2u);
}

}  // namespace
}  // namespace cariesim
