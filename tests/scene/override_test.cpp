// Parameter overrides (scene/scene.hpp, docs/scene-format.md "Overrides"): a node of the document
// replaced before the reader sees it, checked by the same rules and messages as the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <tuple>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

using ::testing::HasSubstr;

// One block with a lesion on top, and a soft object beside it.
constexpr const char* kScene = R"(objects:
  - name: block
    shape: {type: cuboid, size: [10, 20, 5]}
    tissue: generic
    material: {stiffness: 1.0}
  - name: gum
    shape: {type: cuboid, size: [4, 4, 4]}
    tissue: gingiva
lesions:
  - name: top
    object: block
    placement: {at: [0, 0, 2.5], normal: [0, 0, 1]}
    shape: {type: disk, size: 3, depth: 1}
    material: {k_c: 0.8, f_p_star: 2.0}
)";

// Parses kScene with `overrides` ("KEY=VALUE" each) and returns the error message, or fails the test.
std::string error_of(const std::vector<std::string>& sets, const std::string& yaml = kScene) {
  std::vector<SceneOverride> overrides;
  for (const std::string& s : sets) overrides.push_back(parse_override(s));
  try {
    (void)parse_scene(yaml, "test.yaml", overrides);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "parsed without error";
  return {};
}

// The message after its location ("test.yaml:L:C: " or "test.yaml (override KEY): ").
std::string after_location(const std::string& message) {
  const std::size_t at = message.find(": ");
  return at == std::string::npos ? message : message.substr(at + 2);
}

// The error of parsing `yaml` as a file.
std::string file_error_of(const std::string& yaml) {
  try {
    (void)parse_scene(yaml, "test.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "parsed without error:\n" << yaml;
  return {};
}

// `yaml` with the first `from` replaced by `to`.
std::string edited(std::string yaml, const std::string& from, const std::string& to) {
  const std::size_t at = yaml.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return yaml.replace(at, from.size(), to);
}

TEST(SceneOverride, ReplacesValuesAsTheFileWould) {
  const SceneOverride kc = parse_override("lesions[0].material.k_c=0.4");
  const SceneOverride stiffness = parse_override(" objects[0].material.stiffness = 2.0");
  EXPECT_EQ(stiffness.key, "objects[0].material.stiffness");
  const std::vector<SceneOverride> overrides{kc, stiffness};
  const SceneDesc s = parse_scene(kScene, "test.yaml", overrides);
  ASSERT_EQ(s.lesions.size(), 1u);
  EXPECT_DOUBLE_EQ(s.lesions[0].material.k_c.values[0], 0.4);
  EXPECT_DOUBLE_EQ(s.objects[0].material.stiffness, 2.0);
  EXPECT_DOUBLE_EQ(s.lesions[0].material.f_p_star, 2.0);  // the rest as written
  EXPECT_EQ(s.overrides, overrides);

  // The same scene as the file with those values written in it.
  const SceneDesc file = parse_scene(edited(edited(kScene, "k_c: 0.8", "k_c: 0.4"),
                                            "material: {stiffness: 1.0}", "material: {stiffness: 2.0}"),
                                     "test.yaml");
  EXPECT_EQ(file.lesions[0].material.k_c.values, s.lesions[0].material.k_c.values);
  EXPECT_EQ(file.objects[0].material.stiffness, s.objects[0].material.stiffness);
}

TEST(SceneOverride, CreatesMissingMappingsAndTakesStructuredValues) {
  // No `device` section in the file: the path below it is made; a k_c profile is a YAML value.
  const std::vector<SceneOverride> overrides{
      parse_override("device.max_force=5"),
      parse_override("lesions[0].material.k_c={gradient: {top: 1, bottom: 3}}"),
      parse_override("objects[1].material.mu_s=0.25")};
  const SceneDesc s = parse_scene(kScene, "test.yaml", overrides);
  EXPECT_DOUBLE_EQ(s.limits.max_force, 5.0);
  EXPECT_EQ(s.lesions[0].material.k_c.kind, KcProfile::Kind::Gradient);
  EXPECT_DOUBLE_EQ(s.lesions[0].material.k_c.values[1], 3.0);
  EXPECT_DOUBLE_EQ(s.objects[1].material.mu_s, 0.25);
}

TEST(SceneOverride, UnknownKeysGetTheFilesMessageLocatedAtTheOverride) {
  const std::string message = error_of({"objects[0].material.stifness=2"});
  EXPECT_THAT(message, HasSubstr("test.yaml (override objects[0].material.stifness): "));
  const std::string file =
      file_error_of(edited(kScene, "material: {stiffness: 1.0}", "material: {stiffness: 1.0, stifness: 2}"));
  EXPECT_THAT(file, HasSubstr("did you mean 'stiffness'?"));
  EXPECT_EQ(after_location(message), after_location(file));

  // An unknown section: refused at the key the override made.
  const std::string section = error_of({"lesions[0].materal.k_c=1"});
  EXPECT_THAT(section,
              HasSubstr("test.yaml (override lesions[0].materal.k_c): lesions[0].materal: unknown key "
                        "(did you mean 'material'?"));
}

TEST(SceneOverride, OutOfRangeValuesGetTheFilesMessage) {
  for (const auto& [set, from, to] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"lesions[0].material.f_p_star=-1", "f_p_star: 2.0", "f_p_star: -1"},
           {"lesions[0].material.k_c=nan", "k_c: 0.8", "k_c: nan"},
           {"objects[0].material.stiffness=1e9", "material: {stiffness: 1.0}", "material: {stiffness: 1e9}"},
           {"objects[1].material.stiffness=rigid", "tissue: gingiva",
            "tissue: gingiva\n    material: {stiffness: rigid}"},
       }) {
    const std::string message = error_of({set});
    const std::string key = set.substr(0, set.find('='));
    EXPECT_THAT(message, HasSubstr("test.yaml (override " + key + "): ")) << set;
    EXPECT_EQ(after_location(message), after_location(file_error_of(edited(kScene, from, to)))) << set;
  }
}

TEST(SceneOverride, PathsThatDoNotFitTheSceneAreNamed) {
  EXPECT_THAT(
      error_of({"lesions[3].material.k_c=1"}),
      HasSubstr("test.yaml (override lesions[3].material.k_c): lesions has 1 entry (indices from 0)"));
  EXPECT_THAT(error_of({"objects[0].name.x=1"}), HasSubstr("objects[0].name is a scalar, not a mapping"));
  EXPECT_THAT(error_of({"objects.x=1"}), HasSubstr("objects is a sequence, not a mapping"));
  EXPECT_THAT(error_of({"tool[0]=1"}), HasSubstr("tool is not in the scene, so it has no entry 0"));
  // A value that is no YAML is located at the override.
  EXPECT_THAT(error_of({"lesions[0].material.k_c=[1, 2"}),
              HasSubstr("test.yaml (override lesions[0].material.k_c):"));
}

TEST(SceneOverride, MalformedAssignmentsAreRefused) {
  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {"lesions[0].material.k_c", "expected KEY=VALUE"},
           {"=1", "expected a field name"},
           {"a..b=1", "character 3: expected a field name"},
           {"a[x]=1", "'x' is not an index"},
           {"a[1=1", "'[' without ']'"},
           {"a b=1", "unexpected ' '"},
           {"a.=1", "expected a field name"},
       }) {
    try {
      (void)parse_override(text);
      ADD_FAILURE() << text << " was accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("--set '" + text + "'")) << text;
      EXPECT_THAT(e.what(), HasSubstr(expected)) << text;
    }
  }
  // Only the first '=' splits: the value may hold one.
  EXPECT_EQ(parse_override("name=a=b").value, "a=b");
}

TEST(SceneOverride, OverridesChangeTheSceneHashAndNoneKeepIt) {
  const SceneDesc plain = parse_scene(kScene, "test.yaml");
  EXPECT_EQ(parse_scene(kScene, "test.yaml", {}).source_hash, plain.source_hash);
  const std::vector<SceneOverride> a{parse_override("lesions[0].material.k_c=0.4")};
  const std::vector<SceneOverride> b{parse_override("lesions[0].material.k_c=0.5")};
  EXPECT_NE(parse_scene(kScene, "test.yaml", a).source_hash, plain.source_hash);
  EXPECT_NE(parse_scene(kScene, "test.yaml", a).source_hash, parse_scene(kScene, "test.yaml", b).source_hash);
}

TEST(SceneOverride, BuiltInScenesAndTheirTextTakeOverrides) {
  const std::vector<SceneOverride> overrides{parse_override("lesions[0].material.mu_s=0.7")};
  const SceneDesc s = load_scene("friction-block", overrides);
  EXPECT_DOUBLE_EQ(s.lesions[0].material.mu_s, 0.7);
  EXPECT_EQ(s.origin, "builtin:friction-block");
  // The text form (a study trial's scene) reads back to the same values.
  const std::string text =
      override_scene_text(builtin_scene_yaml("friction-block"), "builtin:friction-block", overrides);
  EXPECT_DOUBLE_EQ(parse_scene(text, "builtin:friction-block").lesions[0].material.mu_s, 0.7);
  // And is checked first, with the located message.
  const std::vector<SceneOverride> bad{parse_override("lesions[0].material.mu_s=-1")};
  EXPECT_THROW((void)override_scene_text(builtin_scene_yaml("friction-block"), "builtin:friction-block", bad),
               Error);
}

}  // namespace
}  // namespace cariesim
