#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"
#include "support/fifo.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;

// A minimal valid scene; tests append to or edit it.
constexpr const char* kMinimal = R"(objects:
  - name: block
    shape: {type: cuboid, size: [10, 20, 5]}
)";

// Parses `yaml` and returns the Error message; fails the test when it parses.
std::string error_of(const std::string& yaml, const std::string& origin = "test.yaml") {
  try {
    (void)parse_scene(yaml, origin);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "parsed without error:\n" << yaml;
  return {};
}

TEST(ParseScene, MinimalSceneHasDefaults) {
  const SceneDesc s = parse_scene(kMinimal, "dir/minimal.yaml");
  EXPECT_EQ(s.name, "minimal");  // the file stem when `name` is absent
  ASSERT_EQ(s.objects.size(), 1u);
  const ObjectDesc& o = s.objects[0];
  EXPECT_EQ(o.shape.kind, ShapeDesc::Kind::Cuboid);
  EXPECT_EQ(o.shape.size, Vec3(10, 20, 5));
  EXPECT_EQ(o.kind, ObjectKind::Rigid);
  EXPECT_EQ(o.material.tissue, Tissue::Generic);
  EXPECT_TRUE(std::isinf(o.material.stiffness));
  EXPECT_EQ(o.tree.params.mode, TreeMode::Tight);
  EXPECT_FALSE(o.tree.voxel.has_value());
  EXPECT_TRUE(s.lesions.empty());
  EXPECT_DOUBLE_EQ(s.gains.k_trans, s.limits.max_stiffness);
  EXPECT_EQ(o.where.line, 2);
  EXPECT_EQ(o.where.column, 5);
}

TEST(ParseScene, ReadsEveryField) {
  const std::string yaml = R"(name: full
description: every field
format: 1
objects:
  - name: tooth
    fdi: 46
    shape: {type: molar, mesiodistal: 10.5, buccolingual: 9.5, crown_height: 7, root_length: 12, cusps: 4, roots: 2, resolution: 0.2}
    pose: {position: [1, 2, 3], rotation: {axis: [0, 0, 2], angle: 90}}
    tissue: enamel
    enamel_thickness: 1.2
    material: {mu_s: 0.1, mu_d: 0.05}
    tree: {mode: octree, depth: 5, tolerance: 0.02, max_radius: 0.8, min_radius: 0.03, voxel: 0.04, max_leaves: 30000, fill_interior: false, branching: 8}
  - name: gum
    shape: {type: gingiva, path: [[0, 0, 0], [10, 0, 0]], width: 12, height: 3}
    tissue: gingiva
lesions:
  - name: l1
    object: tooth
    placement: {at: [0, 0, 7], normal: [0, 0, 3], tangent: [0, 1, 0], frame: object, snap: false}
    shape: {type: stripe, size: 3, width: 0.7, depth: 1.1}
    severity: severe
    material:
      mu_s: 0.6
      anisotropic: {direction: [1, 0, 0], mu_s: 0.9, mu_d: 0.7}
      k_c: {layers: [{to: 1.0, k_c: 0.5}, {to: 2.0, k_c: 0.1}]}
      f_p_star: 2.5
      f_e_star: 0.8
      k_theta: 90
  - name: l2
    object: tooth
    placement: {at: [20, 0, 7], normal: [0, 0, 1], frame: world}
    shape: {type: polygon, points: [[0, 0], [0, 1], [1, 1], [1, 0]], depth: 0.5}
    material: {k_c: {gradient: {top: 0.6, bottom: 0.2}}, stiffness: rigid}
tool:
  tip_radius: 0.06
  bend_angle: 90
  home: {position: [0, 0, 30]}
device: {max_force: 10, max_stiffness: 2.0, max_torque: 300, position_resolution: 0.01, workspace: {min: [-50, -50, -50], max: [50, 50, 50]}}
servo_rate: 2000
)";
  const SceneDesc s = parse_scene(yaml, "full.yaml");
  EXPECT_EQ(s.name, "full");
  ASSERT_EQ(s.objects.size(), 2u);
  const ObjectDesc& tooth = s.objects[0];
  EXPECT_EQ(tooth.fdi, 46);
  EXPECT_EQ(tooth.shape.kind, ShapeDesc::Kind::Molar);
  EXPECT_DOUBLE_EQ(tooth.shape.molar.mesiodistal, 10.5);
  EXPECT_EQ(tooth.shape.molar.cusps, 4);
  // 90 degrees about z maps x onto y.
  EXPECT_TRUE((tooth.pose.q * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-12));
  EXPECT_EQ(tooth.pose.p, Vec3(1, 2, 3));
  ASSERT_TRUE(tooth.enamel_thickness.has_value());
  EXPECT_DOUBLE_EQ(*tooth.enamel_thickness, 1.2);
  EXPECT_DOUBLE_EQ(tooth.material.mu_s, 0.1);
  EXPECT_EQ(tooth.tree.params.mode, TreeMode::Octree);
  EXPECT_EQ(tooth.tree.params.depth, 5);
  EXPECT_EQ(tooth.tree.params.branching, 8);
  EXPECT_FALSE(tooth.tree.params.fill_interior);
  ASSERT_TRUE(tooth.tree.voxel.has_value());
  EXPECT_DOUBLE_EQ(*tooth.tree.voxel, 0.04);

  // Soft tissue defaults: kind soft, finite stiffness.
  EXPECT_EQ(s.objects[1].kind, ObjectKind::Soft);
  EXPECT_TRUE(std::isfinite(s.objects[1].material.stiffness));
  EXPECT_EQ(s.objects[1].shape.gingiva.path.size(), 2u);

  ASSERT_EQ(s.lesions.size(), 2u);
  const LesionDesc& l1 = s.lesions[0];
  EXPECT_EQ(l1.object, 0);
  EXPECT_FALSE(l1.snap);
  EXPECT_EQ(l1.shape.kind, LesionShape::Kind::Stripe);
  EXPECT_DOUBLE_EQ(l1.shape.width, 0.7);
  EXPECT_TRUE(l1.shape.normal.isApprox(Vec3::UnitZ()));  // normalized
  EXPECT_EQ(l1.severity, "severe");
  // Preset values survive unless overridden.
  const Material severe = caries_preset(CariesPreset::Severe);
  EXPECT_DOUBLE_EQ(l1.material.mu_s, 0.6);
  EXPECT_DOUBLE_EQ(l1.material.mu_d, severe.mu_d);
  EXPECT_DOUBLE_EQ(l1.material.k_e, severe.k_e);
  EXPECT_EQ(l1.material.tissue, Tissue::Caries);
  EXPECT_EQ(l1.material.aniso_dir, Vec3::UnitX());
  EXPECT_DOUBLE_EQ(l1.material.mu_s_along, 0.9);
  EXPECT_EQ(l1.material.k_c.kind, KcProfile::Kind::Layers);
  EXPECT_DOUBLE_EQ(l1.material.k_c.at(0.5), 0.5);
  EXPECT_DOUBLE_EQ(l1.material.k_c.at(1.5), 0.1);
  EXPECT_DOUBLE_EQ(l1.material.f_p_star, 2.5);
  EXPECT_DOUBLE_EQ(l1.material.k_theta, 90.0);

  const LesionDesc& l2 = s.lesions[1];
  EXPECT_TRUE(l2.world_frame);
  EXPECT_EQ(l2.severity, "");
  EXPECT_TRUE(l2.material.rigid());
  // The gradient reaches its bottom value at the lesion's depth by default.
  EXPECT_DOUBLE_EQ(l2.material.k_c.at(0.0), 0.6);
  EXPECT_DOUBLE_EQ(l2.material.k_c.at(0.5), 0.2);
  // A clockwise polygon is made counter-clockwise.
  ASSERT_EQ(l2.shape.polygon.size(), 4u);
  double area = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    const auto& a = l2.shape.polygon[i];
    const auto& b = l2.shape.polygon[(i + 1) % 4];
    area += a.x() * b.y() - b.x() * a.y();
  }
  EXPECT_GT(area, 0.0);

  EXPECT_DOUBLE_EQ(s.tool.tip_radius, 0.06);
  EXPECT_NEAR(s.tool.bend_angle, std::numbers::pi / 2, 1e-12);
  ASSERT_TRUE(s.tool_home.has_value());
  EXPECT_EQ(s.tool_home->p, Vec3(0, 0, 30));
  EXPECT_DOUBLE_EQ(s.limits.max_force, 10.0);
  EXPECT_DOUBLE_EQ(s.gains.k_trans, 2.0);  // follows the device's maximum stiffness
  EXPECT_EQ(s.limits.workspace.min(), Vec3(-50, -50, -50));
  EXPECT_DOUBLE_EQ(s.servo_rate, 2000.0);
}

TEST(ParseScene, LesionShapeInWorldFollowsTheHostPose) {
  const std::string yaml =
      std::string(kMinimal) + R"(    pose: {position: [5, 0, 0], rotation: {axis: [0, 0, 1], angle: 90}}
lesions:
  - name: l
    object: block
    placement: {at: [1, 0, 0], normal: [1, 0, 0]}
    shape: {type: disk, size: 2, depth: 1}
)";
  const SceneDesc s = parse_scene(yaml, "t.yaml");
  const LesionShape w = lesion_shape_in_world(s, s.lesions[0]);
  EXPECT_TRUE(w.center.isApprox(Vec3(5, 1, 0), 1e-12));
  EXPECT_TRUE(w.normal.isApprox(Vec3(0, 1, 0), 1e-12));
}

TEST(ParseSceneErrors, WrongTypeNamesTheFieldAndPosition) {
  const std::string yaml = std::string(kMinimal) + "    pose: {position: 5}\n";
  const std::string message = error_of(yaml);
  EXPECT_THAT(message,
              HasSubstr("test.yaml:4:22: objects[0].pose.position: expected a sequence of 3 numbers"));
}

TEST(ParseSceneErrors, WrongTypeInsideASequence) {
  const std::string yaml = R"(objects:
  - name: block
    shape: {type: cuboid, size: [10, twenty, 5]}
)";
  EXPECT_THAT(error_of(yaml),
              HasSubstr("test.yaml:3:38: objects[0].shape.size[1]: expected a number, got 'twenty'"));
}

TEST(ParseSceneErrors, MissingRequiredField) {
  const std::string yaml = R"(objects:
  - name: block
    pose: {position: [0, 0, 0]}
)";
  EXPECT_THAT(error_of(yaml), HasSubstr("test.yaml:2:5: objects[0].shape: missing required field"));
  EXPECT_THAT(error_of("name: x\n"), HasSubstr("test.yaml:1:1: objects: missing required field"));
}

TEST(ParseSceneErrors, UnknownKeyIsATypo) {
  const std::string yaml = std::string(kMinimal) + "    pose: {postion: [0, 0, 0]}\n";
  const std::string message = error_of(yaml);
  EXPECT_THAT(message, HasSubstr("test.yaml:4:12: objects[0].pose.postion: unknown key"));
  EXPECT_THAT(message, HasSubstr("did you mean 'position'?"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "colour: red\n"),
              HasSubstr("test.yaml:4:1: colour: unknown key"));
}

TEST(ParseSceneErrors, BadEnumValues) {
  EXPECT_THAT(
      error_of(std::string(kMinimal) + "    tissue: bone\n"),
      HasSubstr("test.yaml:4:13: objects[0].tissue: unknown tissue 'bone' (expected one of: enamel,"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    kind: squishy\n"),
              HasSubstr("test.yaml:4:11: objects[0].kind: unknown kind 'squishy'"));
  EXPECT_THAT(error_of("objects:\n  - {name: a, shape: {type: sphere}}\n"),
              HasSubstr("test.yaml:2:29: objects[0].shape.type: unknown shape type 'sphere'"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    tree: {mode: kdtree}\n"),
              HasSubstr("objects[0].tree.mode: unknown tree mode 'kdtree'"));
}

// A scene with one lesion whose fields the test replaces.
std::string with_lesion(const std::string& lesion_fields) {
  return std::string(kMinimal) + "lesions:\n  - name: l\n    object: block\n" + lesion_fields;
}

TEST(ParseSceneErrors, LesionProblems) {
  const std::string placement = "    placement: {at: [0, 0, 0], normal: [0, 0, 1]}\n";
  const std::string shape = "    shape: {type: disk, size: 2, depth: 1}\n";
  EXPECT_THAT(error_of(with_lesion(placement + shape + "    severity: moderate\n")),
              HasSubstr("lesions[0].severity: unknown severity 'moderate' (expected one of: mild, severe)"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "lesions:\n  - {name: l, object: tooth99}\n"),
              HasSubstr("test.yaml:5:23: lesions[0].object: unknown object 'tooth99' (objects: block)"));
  EXPECT_THAT(error_of(with_lesion(placement + "    shape: {type: star, size: 2, depth: 1}\n")),
              HasSubstr("lesions[0].shape.type: unknown lesion shape 'star'"));
  EXPECT_THAT(error_of(with_lesion(placement + "    shape: {type: disk, size: 2, width: 1, depth: 1}\n")),
              HasSubstr("lesions[0].shape.width: unknown key"));
  EXPECT_THAT(error_of(with_lesion("    placement: {at: [0, 0, 0], normal: [0, 0, 0]}\n" + shape)),
              HasSubstr("lesions[0].placement.normal: expected a non-zero direction"));
  EXPECT_THAT(error_of(with_lesion("    placement: {at: [0, 0, 0], normal: [0, 0, 1], tangent: [0, 0, 2]}\n" +
                                   shape)),
              HasSubstr("lesions[0].placement.tangent: must not be parallel to the normal"));
  EXPECT_THAT(error_of(with_lesion(placement + shape +
                                   "    material: {k_c: {layers: [{to: 2, k_c: 1}, {to: 1, k_c: 1}]}}\n")),
              HasSubstr("lesions[0].material.k_c.layers[1].to: must be deeper than the layer above"));
  EXPECT_THAT(error_of(with_lesion(placement + shape +
                                   "    material: {k_c: {layers: [], gradient: {top: 1, bottom: 2}}}\n")),
              HasSubstr("lesions[0].material.k_c: expected a number (N/mm), or exactly one of"));
  EXPECT_THAT(error_of(with_lesion(placement + shape +
                                   "    material: {anisotropic: {direction: [1, 0, 0], mu_s: 0.5}}\n")),
              HasSubstr("lesions[0].material.anisotropic.mu_d: missing required field"));
  EXPECT_THAT(error_of(with_lesion(
                  placement + "    shape: {type: polygon, points: [[0, 0], [1, 1], [2, 2]], depth: 1}\n")),
              HasSubstr("lesions[0].shape.points: the polygon has no area"));
}

TEST(ParseSceneErrors, OutOfRangeValues) {
  EXPECT_THAT(error_of("objects:\n  - {name: a, shape: {type: cuboid, size: [10, -2, 5]}}\n"),
              HasSubstr("objects[0].shape.size: edge lengths must be > 0"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    material: {mu_s: -0.1}\n"),
              HasSubstr("test.yaml:4:22: objects[0].material.mu_s: -0.1 is out of range [0, 5]"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    material: {mu_d: .nan}\n"),
              HasSubstr("objects[0].material.mu_d: expected a number, got '.nan'"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    material: {stiffness: soft}\n"),
              HasSubstr("objects[0].material.stiffness: expected a number (N/mm) or 'rigid', got 'soft'"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    material: {stiffness: 0}\n"),
              HasSubstr("objects[0].material.stiffness: 0 is out of range: expected > 0"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    fdi: 49\n"),
              HasSubstr("objects[0].fdi: 49 is out of range [11, 48]"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    fdi: 30\n"),
              HasSubstr("objects[0].fdi: 30 is not an FDI tooth number"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "servo_rate: 1e9\n"),
              HasSubstr("test.yaml:4:13: servo_rate: 1000000000 is out of range [100, 10000] Hz"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    tree: {min_radius: 2, max_radius: 1}\n"),
              HasSubstr("objects[0].tree.min_radius: 2 mm must be below max_radius (1 mm)"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    tissue: gingiva\n    material: {stiffness: rigid}\n"),
              HasSubstr("objects[0].material.stiffness: a soft object needs a finite stiffness"));
  EXPECT_THAT(error_of("objects:\n  - {name: m, shape: {type: molar, mesiodistal: 25}}\n"),
              HasSubstr("objects[0].shape.mesiodistal: 25 is out of range [5, 20] mm"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "tool: {shank_radius: 5}\n"),
              HasSubstr("tool: radii must grow from the tip to the handle"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "tool: {bend_radius: 0.3}\n"),
              HasSubstr("test.yaml:4:21: tool.bend_radius: must exceed working_end_radius (0.45 mm)"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    tree: {depth: 4.5}\n"),
              HasSubstr("objects[0].tree.depth: expected an integer, got '4.5'"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    pose: {position: ['1', 0, 0]}\n"),
              HasSubstr("objects[0].pose.position[0]: expected a number"));
}

// Issue #14 item 9: `scene check` said ok to scenes the builder or the servo loop then refused.
TEST(SceneParse, WhatTheBuilderAndTheServoLoopRefuseIsRefusedHere) {
  // servo_rate 20000 passed the check and failed in `cariesim servo` (at most 10 kHz).
  EXPECT_THAT(error_of(std::string(kMinimal) + "servo_rate: 20000\n"),
              HasSubstr("test.yaml:4:13: servo_rate: 20000 is out of range [100, 10000] Hz"));
  // A 1e-6 mm cuboid passed the check; the builder threw from make_cuboid or built an empty tree.
  EXPECT_THAT(
      error_of("objects:\n  - name: speck\n    shape: {type: cuboid, size: [1e-6, 1e-6, 1e-6]}\n"),
      HasSubstr("test.yaml:3:33: objects[0].shape.size: edge 1e-06 mm is below the smallest a cuboid may "
                "have, 0.01 mm"));
  EXPECT_THAT(
      error_of("objects:\n  - name: grain\n    shape: {type: cuboid, size: [0.05, 0.05, 0.05]}\n"),
      HasSubstr("objects[0].shape.size: edge 0.05 mm is thinner than two level-set voxels of its tight "
                "tree (2 x 0.05 mm)"));
  // The same grain in an octree, or with a finer tolerance, builds: it is accepted.
  EXPECT_NO_THROW(
      parse_scene("objects:\n  - name: grain\n    shape: {type: cuboid, size: [0.05, 0.05, 0.05]}\n"
                  "    tree: {mode: octree}\n",
                  "test.yaml"));
  EXPECT_NO_THROW(parse_scene("objects:\n  - name: grain\n    shape: {type: cuboid, size: [0.1, 0.1, 0.1]}\n",
                              "test.yaml"));
}

// Issue #14 item 9: a directory given as a mesh was "not found".
TEST(SceneParse, ADirectoryAsAMeshIsNamedAsSuch) {
  const std::string dir = std::filesystem::temp_directory_path().string();
  EXPECT_THAT(error_of("objects:\n  - name: m\n    shape: {type: mesh, file: '" + dir + "'}\n"),
              HasSubstr("objects[0].shape.file: " + std::filesystem::path(dir).lexically_normal().string() +
                        ": not a regular file (a folder), not a mesh file"));
}

// Issue 26 item 13: a FIFO or /dev/zero as a mesh was "mesh file not found" (and reading one would
// block or run without end). Each is named by its kind where the scene names it.
TEST(SceneParse, AFifoOrADeviceAsAMeshIsNamedByItsKind) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cariesim_parse_fifo_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(test::make_fifo(dir / "tooth.stl"));
  EXPECT_THAT(error_of("objects:\n  - name: m\n    shape: {type: mesh, file: tooth.stl}\n",
                       (dir / "s.yaml").string()),
              HasSubstr("s.yaml:3:31: objects[0].shape.file: " + (dir / "tooth.stl").string() +
                        ": not a regular file (a FIFO (named pipe)), not a mesh file"));
  EXPECT_THAT(error_of("objects:\n  - name: m\n    shape: {type: mesh, file: /dev/zero}\n"),
              HasSubstr("objects[0].shape.file: /dev/zero: not a regular file (a character device)"));
  std::filesystem::remove_all(dir);
}

// A second YAML document was ignored (YAML::Load reads the first): what follows `---` is refused.
TEST(ParseSceneErrors, ASecondDocumentIsRefused) {
  EXPECT_THAT(error_of(std::string(kMinimal) + "---\nobjects: []\n"),
              HasSubstr("test.yaml:5:1: a second YAML document (after `---`): a file holds exactly one"));
}

TEST(ParseSceneErrors, SceneWideChecks) {
  EXPECT_THAT(error_of(std::string(kMinimal) + "  - {name: block, shape: {type: tongue}}\n"),
              HasSubstr("test.yaml:4:12: objects[1].name: duplicate object name 'block'"));
  EXPECT_THAT(error_of("objects:\n  - {name: a, fdi: 46, shape: {type: molar}}\n  - {name: b, fdi: 46, "
                       "shape: {type: molar}}\n"),
              HasSubstr("test.yaml:3:20: objects[1].fdi: tooth 46 appears twice"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "    tissue: enamel\n    tissue: dentin\n"),
              HasSubstr("test.yaml:5:5: objects[0].tissue: duplicate key"));
  EXPECT_THAT(error_of("objects: []\n"), HasSubstr("objects: a scene needs at least one object"));
  EXPECT_THAT(error_of("objects:\n  - {name: g, shape: {type: tongue}, tissue: tongue}\nlesions:\n  - {name: "
                       "l, object: g}\n"),
              HasSubstr("lesions[0].object: 'g' is soft; lesions need a rigid host"));
  EXPECT_THAT(error_of(std::string(kMinimal) + "format: 2\n"), HasSubstr("format: 2 is out of range [1, 1]"));
}

TEST(ParseSceneErrors, SyntaxErrorsAreLocated) {
  const std::string message = error_of("objects:\n  - name: [unclosed\n");
  EXPECT_THAT(message, HasSubstr("test.yaml:"));
  EXPECT_THAT(message, HasSubstr("YAML syntax error"));
  EXPECT_THAT(error_of(""), HasSubstr("test.yaml:1:1: expected a mapping"));
  EXPECT_THAT(error_of("- 1\n- 2\n"), HasSubstr("test.yaml:1:1: expected a mapping, got a sequence"));
}

// An alias inside the node it names makes an endless document: refused by the document opener
// (io::parse_document), before the scene's fields are read.
TEST(ParseSceneErrors, SelfReferencingAliasesAreRejected) {
  EXPECT_THAT(error_of("objects: &x [*x]\n"),
              HasSubstr("test.yaml:1:10: an alias names a node that contains it"));
  EXPECT_THAT(error_of("objects:\n  - &o {name: a, shape: {type: cuboid, size: [1, 1, 1]}, pose: *o}\n"),
              HasSubstr("an alias names a node that contains it"));
}

TEST(ParseSceneErrors, MissingMeshFileIsNamed) {
  const std::string yaml = "objects:\n  - name: scan\n    shape: {type: mesh, file: nowhere/tooth.stl}\n";
  const std::string message = error_of(yaml, "/tmp/scenes/x.yaml");
  EXPECT_THAT(message, HasSubstr("/tmp/scenes/x.yaml:3:31: objects[0].shape.file: mesh file not found: "
                                 "/tmp/scenes/nowhere/tooth.stl"));
}

TEST(ParseScene, MeshPathIsRelativeToTheSceneFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cariesim_parse_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "meshes");
  std::ofstream(dir / "meshes" / "part.stl") << "solid empty\nendsolid empty\n";
  std::ofstream(dir / "scene.yaml")
      << "objects:\n  - name: scan\n    shape: {type: mesh, file: meshes/part.stl, scale: 2}\n";
  const SceneDesc s = load_scene((dir / "scene.yaml").string());
  EXPECT_EQ(s.objects[0].shape.file, (dir / "meshes" / "part.stl").lexically_normal());
  EXPECT_DOUBLE_EQ(s.objects[0].shape.scale, 2.0);
  std::filesystem::remove_all(dir);
}

// "data:PATH" is PATH in the shipped data folder, wherever the scene lies: the build's data/ folder,
// or $CARIESIM_DATA_DIR when set.
TEST(ParseScene, DataPrefixReadsTheShippedDataFolder) {
  ASSERT_EQ(::unsetenv("CARIESIM_DATA_DIR"), 0);
  EXPECT_EQ(data_directory(), std::filesystem::path(CARIESIM_DATA_DIR));
  const std::string yaml =
      "objects:\n  - name: scan\n    shape: {type: mesh, file: "
      "'data:open-full-jaw/patient26/tooth_30.ply'}\n";
  const SceneDesc s = parse_scene(yaml, "/elsewhere/scene.yaml");
  EXPECT_EQ(
      s.objects[0].shape.file,
      (std::filesystem::path(CARIESIM_DATA_DIR) / "open-full-jaw/patient26/tooth_30.ply").lexically_normal());

  // Another folder through the environment; a file missing there is named with the folder.
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cariesim_data_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "scans");
  std::ofstream(dir / "scans" / "part.stl") << "solid empty\nendsolid empty\n";
  ASSERT_EQ(::setenv("CARIESIM_DATA_DIR", dir.c_str(), 1), 0);
  EXPECT_EQ(parse_scene("objects:\n  - name: scan\n    shape: {type: mesh, file: 'data:scans/part.stl'}\n",
                        "x.yaml")
                .objects[0]
                .shape.file,
            (dir / "scans" / "part.stl").lexically_normal());
  const std::string missing =
      error_of("objects:\n  - name: scan\n    shape: {type: mesh, file: 'data:scans/tooth_99.ply'}\n");
  EXPECT_THAT(missing, HasSubstr("objects[0].shape.file: mesh file not found: " +
                                 (dir / "scans" / "tooth_99.ply").string()));
  EXPECT_THAT(missing, HasSubstr("in the data folder " + dir.string()));
  EXPECT_THAT(error_of("objects:\n  - name: scan\n    shape: {type: mesh, file: 'data:'}\n"),
              HasSubstr("expected a relative path after 'data:'"));
  EXPECT_THAT(error_of("objects:\n  - name: scan\n    shape: {type: mesh, file: 'data:/etc/passwd'}\n"),
              HasSubstr("expected a relative path after 'data:'"));
  ASSERT_EQ(::unsetenv("CARIESIM_DATA_DIR"), 0);
  std::filesystem::remove_all(dir);
}

TEST(LoadScene, UnknownNameListsTheBuiltIns) {
  try {
    (void)load_scene("no-such-scene");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no-such-scene: no such scene file"));
    EXPECT_THAT(e.what(), HasSubstr("oral-cavity"));
  }
}

}  // namespace
}  // namespace cariesim
