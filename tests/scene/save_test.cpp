// Saving lesion materials back into scene files (src/scene/save.cpp): the edited fields round-trip
// through the parser, other content stays, backups, and errors that name the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"
#include "support/files.hpp"

namespace {

namespace fs = std::filesystem;
using cariesim::Error;
using cariesim::KcProfile;
using cariesim::LesionMaterialEdit;
using cariesim::Material;
using ::testing::HasSubstr;

using cariesim::test::read_text;

// The named lesion's material as the parser sees it.
const Material& lesion_material(const cariesim::SceneDesc& scene, const std::string& name) {
  for (const auto& l : scene.lesions)
    if (l.name == name) return l.material;
  throw std::runtime_error("no lesion " + name);
}

// Every slider field written for one lesion comes back from the parser; the rest of the scene stays.
TEST(SaveLesionMaterials, EditedFieldsRoundTrip) {
  const std::string yaml(cariesim::builtin_scene_yaml("friction-block"));
  Material m = lesion_material(cariesim::parse_scene(yaml, "builtin:friction-block"), "top");
  m.mu_s = 0.42;
  m.mu_d = 0.21;
  m.k_e = 0.77;
  m.stiffness = 0.66;
  m.k_c.kind = KcProfile::Kind::Constant;
  m.k_c.values.fill(1.25);
  m.f_p_star = 4.5;
  m.f_e_star = 0.75;
  m.k_theta = 120.0;
  const std::string out = cariesim::set_lesion_materials(yaml, "edited.yaml", {{"top", m}});
  const cariesim::SceneDesc scene = cariesim::parse_scene(out, "edited.yaml");
  const Material& back = lesion_material(scene, "top");
  EXPECT_DOUBLE_EQ(back.mu_s, 0.42);
  EXPECT_DOUBLE_EQ(back.mu_d, 0.21);
  EXPECT_DOUBLE_EQ(back.k_e, 0.77);
  EXPECT_DOUBLE_EQ(back.stiffness, 0.66);
  EXPECT_EQ(back.k_c.kind, KcProfile::Kind::Constant);
  EXPECT_DOUBLE_EQ(back.k_c.at(0.5), 1.25);
  EXPECT_DOUBLE_EQ(back.f_p_star, 4.5);
  EXPECT_DOUBLE_EQ(back.f_e_star, 0.75);
  EXPECT_DOUBLE_EQ(back.k_theta, 120.0);
  // The objects and the tool are as before.
  const cariesim::SceneDesc original = cariesim::parse_scene(yaml, "builtin:friction-block");
  ASSERT_EQ(scene.objects.size(), original.objects.size());
  EXPECT_TRUE(scene.objects[0].shape.size.isApprox(original.objects[0].shape.size));
  ASSERT_TRUE(scene.tool_home && original.tool_home);
  EXPECT_TRUE(scene.tool_home->p.isApprox(original.tool_home->p));
  EXPECT_EQ(scene.name, original.name);
  // Slider values are written without float noise.
  EXPECT_THAT(out, HasSubstr("mu_s: 0.42"));
}

// A layered k_c keeps its layers; other lesions keep their own materials.
TEST(SaveLesionMaterials, LayeredProfileAndUntouchedLesions) {
  const std::string yaml(cariesim::builtin_scene_yaml("oral-cavity"));
  const cariesim::SceneDesc before = cariesim::parse_scene(yaml, "builtin:oral-cavity");
  Material m = lesion_material(before, "lesion1");
  ASSERT_EQ(m.k_c.kind, KcProfile::Kind::Layers);
  m.mu_s = 0.3;
  const cariesim::SceneDesc after =
      cariesim::parse_scene(cariesim::set_lesion_materials(yaml, "o.yaml", {{"lesion1", m}}), "o.yaml");
  const Material& back = lesion_material(after, "lesion1");
  EXPECT_EQ(back.k_c.kind, KcProfile::Kind::Layers);
  EXPECT_EQ(back.k_c.layer_count, m.k_c.layer_count);
  for (const double depth : {0.5, 1.0, 2.0, 2.4})
    EXPECT_DOUBLE_EQ(back.k_c.at(depth), m.k_c.at(depth)) << depth;
  EXPECT_DOUBLE_EQ(back.mu_s, 0.3);
  const Material& other = lesion_material(after, "lesion3");
  const Material& other_before = lesion_material(before, "lesion3");
  EXPECT_DOUBLE_EQ(other.mu_s, other_before.mu_s);
  EXPECT_DOUBLE_EQ(other.f_p_star, other_before.f_p_star);
}

// Unknown lesions, broken YAML and values the parser rejects are errors naming the file.
TEST(SaveLesionMaterials, ErrorsNameTheFile) {
  const std::string yaml(cariesim::builtin_scene_yaml("friction-block"));
  EXPECT_THAT(
      [&] {
        cariesim::set_lesion_materials(yaml, "a.yaml", {{"nope", Material{}}});
      },
      ::testing::ThrowsMessage<Error>(HasSubstr("a.yaml: no lesion named 'nope'")));
  EXPECT_THAT(
      [&] {
        cariesim::set_lesion_materials("lesions: [", "b.yaml", {{"x", Material{}}});
      },
      ::testing::ThrowsMessage<Error>(HasSubstr("b.yaml:")));
  Material bad;
  bad.mu_s = 50.0;  // above the parser's limit
  EXPECT_THAT(
      [&] {
        cariesim::set_lesion_materials(yaml, "c.yaml", {{"top", bad}});
      },
      ::testing::ThrowsMessage<Error>(HasSubstr("c.yaml")));
}

// Files: a built-in scene goes to a new file; saving over a file keeps the old one as .bak.
TEST(SaveLesionMaterials, WritesFilesWithABackup) {
  const fs::path dir = fs::temp_directory_path() / ("cariesim_save_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path file = dir / "tuned.yaml";
  Material m = lesion_material(cariesim::load_scene("friction-block"), "top");
  m.mu_s = 0.11;
  EXPECT_TRUE(cariesim::save_lesion_materials("friction-block", file, {{"top", m}}).empty());
  EXPECT_DOUBLE_EQ(lesion_material(cariesim::load_scene(file.string()), "top").mu_s, 0.11);
  const std::string first = read_text(file);

  m.mu_s = 0.22;
  const fs::path backup = cariesim::save_lesion_materials(file.string(), file, {{"top", m}});
  EXPECT_EQ(backup, fs::path(file.string() + ".bak"));
  EXPECT_EQ(read_text(backup), first);
  EXPECT_DOUBLE_EQ(lesion_material(cariesim::load_scene(file.string()), "top").mu_s, 0.22);
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));

  // A source that is neither a built-in nor a file.
  EXPECT_THROW(cariesim::save_lesion_materials((dir / "missing.yaml").string(), file, {{"top", m}}), Error);
  fs::remove_all(dir);
}

}  // namespace
