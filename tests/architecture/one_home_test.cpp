// One home per concept (docs/architecture.md "One home per concept"), enforced on the source tree:
// the step's materials are declared once, in the render module; one rule says what is rigid; the
// penetration state is tested through one predicate; the record reaches the step only through its codes
// (render/interaction.hpp); every Device lives in device/. A failure names the file and the line.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace cariesim {
namespace {

namespace fs = std::filesystem;

bool is_source(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".hpp" || ext == ".cpp" || ext == ".h" || ext == ".cc";
}

// Calls `visit(relative path, text)` for every source file under the given top folders.
void for_each_source(const std::vector<std::string>& tops,
                     const std::function<void(const std::string&, const std::string&)>& visit) {
  const fs::path root = CARIESIM_SOURCE_DIR;
  for (const std::string& top : tops) {
    ASSERT_TRUE(fs::is_directory(root / top)) << (root / top);
    for (const auto& entry : fs::recursive_directory_iterator(root / top)) {
      if (!entry.is_regular_file() || !is_source(entry.path())) continue;
      std::ifstream in(entry.path(), std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      visit(fs::relative(entry.path(), root).generic_string(), text.str());
    }
  }
}

// 1-based line of a character offset.
int line_of(const std::string& text, std::size_t offset) {
  return 1 +
         static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(offset), '\n'));
}

// Every match of `pattern` in the tree, as "file:line: match", except in the files `skip` names.
std::vector<std::string> occurrences(const std::regex& pattern, const std::vector<std::string>& tops,
                                     const std::vector<std::string>& skip) {
  std::vector<std::string> found;
  for_each_source(tops, [&](const std::string& file, const std::string& text) {
    if (std::find(skip.begin(), skip.end(), file) != skip.end()) return;
    for (auto it = std::sregex_iterator(text.begin(), text.end(), pattern); it != std::sregex_iterator();
         ++it)
      found.push_back(file + ":" + std::to_string(line_of(text, static_cast<std::size_t>(it->position()))) +
                      ": " + it->str());
  });
  return found;
}

std::string lines(const std::vector<std::string>& v) {
  std::string text;
  for (const std::string& s : v) text += s + "\n";
  return text;
}

const std::vector<std::string> kCode = {"include/cariesim", "src", "apps", "bench", "tests"};

// A declaration of the step's material types (or a second material type of the scene description).
const std::regex& material_declaration() {
  static const std::regex r(
      R"((struct|class)\s+(Material|KcProfile|\w*MaterialDesc)\s*\{|enum\s+class\s+(Tissue|CariesPreset)\b)");
  return r;
}

// The penetration state written out: Inserting || Extracting (either order, across lines).
const std::regex& penetration_written_out() {
  static const std::regex r(
      R"(InteractionState::Inserting\s*\|\|[^;{]*InteractionState::Extracting|InteractionState::Extracting\s*\|\|[^;{]*InteractionState::Inserting)");
  return r;
}

TEST(OneHome, TheStepsMaterialsAreDeclaredOnceInRender) {
  // Material, KcProfile, Tissue and the caries presets: render/material.hpp and nowhere else (no
  // second material type in the scene description, none in spheretree).
  const std::vector<std::string> elsewhere = occurrences(material_declaration(), {"include/cariesim", "src"},
                                                         {"include/cariesim/render/material.hpp"});
  EXPECT_TRUE(elsewhere.empty()) << lines(elsewhere);
  EXPECT_TRUE(fs::is_regular_file(fs::path(CARIESIM_SOURCE_DIR) / "include/cariesim/render/material.hpp"));
}

TEST(OneHome, ThePenetrationStateIsTestedThroughOnePredicate) {
  // `Inserting || Extracting` is penetrating() (render/interaction.hpp); nobody writes it out.
  // (This file spells the pattern out to test it.)
  const std::vector<std::string> found =
      occurrences(penetration_written_out(), kCode,
                  {"include/cariesim/render/interaction.hpp", "tests/architecture/one_home_test.cpp"});
  EXPECT_TRUE(found.empty()) << lines(found);
}

// A rigidity rule spelled out: a walk over a tree's leaves that asks each leaf's material rigid().
const std::regex& rigid_rule_written_out() {
  static const std::regex r(R"(leaf_nodes[\s\S]{0,300}?\.rigid\(\))");
  return r;
}

TEST(OneHome, RigidIsDecidedByOneRule) {
  // Whether an object is rigid is rigid_object / rigid_objects (render/model.hpp): nobody else walks
  // the leaves asking rigid(), and outside collision (which only reads it) CollisionObject::surface_only
  // is written from rigid_object and read by nobody as a rigidity test.
  std::vector<std::string> found = occurrences(
      rigid_rule_written_out(), {"include/cariesim", "src", "apps", "bench"}, {"src/render/model.cpp"});
  const std::regex surface_only(R"(surface_only)");
  for_each_source(
      {"include/cariesim", "src", "apps", "bench"}, [&](const std::string& file, const std::string& text) {
        if (file.find("/collision/") != std::string::npos) return;
        for (auto it = std::sregex_iterator(text.begin(), text.end(), surface_only);
             it != std::sregex_iterator(); ++it) {
          const std::size_t at = static_cast<std::size_t>(it->position());
          const std::size_t begin = text.rfind('\n', at) == std::string::npos ? 0 : text.rfind('\n', at) + 1;
          const std::string line = text.substr(begin, text.find('\n', at) - begin);
          const std::size_t code = line.find_first_not_of(" \t");
          if (line.compare(code, 2, "//") == 0) continue;
          if (line.find("surface_only = rigid_object(") != std::string::npos) continue;
          found.push_back(file + ":" + std::to_string(line_of(text, at)) + ": " + line);
        }
      });
  EXPECT_TRUE(found.empty()) << lines(found);
}

TEST(OneHome, TheRecordReachesTheStepOnlyThroughItsCodes) {
  // The record stores the state and the flags: it includes render/interaction.hpp and no other render
  // header (render/step.hpp would bring the whole model).
  const std::regex render_include(R"(#\s*include\s*["<]cariesim/render/([\w./]+)[">])");
  std::vector<std::string> found;
  for_each_source({"include/cariesim/record", "src/record"}, [&](const std::string& file,
                                                                 const std::string& text) {
    for (auto it = std::sregex_iterator(text.begin(), text.end(), render_include);
         it != std::sregex_iterator(); ++it) {
      if ((*it)[1] != "interaction.hpp")
        found.push_back(file + ":" + std::to_string(line_of(text, static_cast<std::size_t>(it->position()))) +
                        ": " + it->str());
    }
  });
  EXPECT_TRUE(found.empty()) << lines(found);
}

// Playback is written once: every pose blend of the library is common/trajectory.cpp's (the scripted
// and the replay devices share its cursor), and the device factory is the device module's.
TEST(OneHome, PosesAreBlendedOnceAndDevicesMadeInDevice) {
  const std::vector<std::string> blends =
      occurrences(std::regex(R"(\.slerp\()"), {"include/cariesim", "src"}, {"src/common/trajectory.cpp"});
  EXPECT_TRUE(blends.empty()) << lines(blends);
  const std::vector<std::string> factories = occurrences(
      std::regex(R"(std::unique_ptr<Device>\s+make_device\()"), {"include/cariesim", "src", "apps"},
      {"include/cariesim/device/factory.hpp", "src/device/factory.cpp"});
  EXPECT_TRUE(factories.empty()) << lines(factories);
  EXPECT_TRUE(fs::is_regular_file(fs::path(CARIESIM_SOURCE_DIR) / "src/device/factory.cpp"));
}

// A class of the library that is a Device (derives from it).
const std::regex& device_class() {
  static const std::regex r(R"((class|struct)\s+\w+(\s+final)?\s*:\s*(public\s+)?Device\b)");
  return r;
}

// Every Device of the library lives in device/: a module above adds a backend through a source or a
// maker it registers (the record module's recording source for the replay device), not a device of
// its own. The viewer's mouse (apps/) is the application's.
TEST(OneHome, EveryDeviceLivesInDevice) {
  std::vector<std::string> elsewhere;
  for (const std::string& found : occurrences(device_class(), {"include/cariesim", "src"}, {}))
    if (found.rfind("include/cariesim/device/", 0) != 0 && found.rfind("src/device/", 0) != 0)
      elsewhere.push_back(found);
  EXPECT_TRUE(elsewhere.empty()) << lines(elsewhere);
  const std::vector<std::string> in_device = occurrences(device_class(), {"include/cariesim/device"}, {});
  EXPECT_NE(lines(in_device).find("class ReplayDevice : public Device"), std::string::npos)
      << lines(in_device);
}

TEST(OneHome, TheCheckersFindWhatTheyLookFor) {
  // The patterns themselves, on the forms they must catch (a wrong pattern would pass vacuously).
  const std::regex& written_out = penetration_written_out();
  EXPECT_TRUE(std::regex_search(
      "const bool inside =\n      s.interaction == InteractionState::Inserting || s.interaction == "
      "InteractionState::Extracting;",
      written_out));
  EXPECT_TRUE(std::regex_search(
      "(o.state == InteractionState::Extracting || o.state == InteractionState::Inserting)", written_out));
  EXPECT_FALSE(
      std::regex_search("if (s.interaction == InteractionState::Inserting && f_e > mat.f_e_star)\n"
                        "    s.interaction = InteractionState::Extracting;",
                        written_out));
  const std::regex& rule = rigid_rule_written_out();
  EXPECT_TRUE(
      std::regex_search("std::all_of(tree.leaf_nodes.begin(), tree.leaf_nodes.end(), [&](uint32_t node) {\n"
                        "  const uint16_t material = tree.nodes[node].material;\n"
                        "  return material < materials.size() && materials[material].rigid();",
                        rule));
  EXPECT_FALSE(std::regex_search("const bool compliant = !mat.rigid();", rule));
  const std::regex& declaration = material_declaration();
  EXPECT_TRUE(std::regex_search("struct ObjectMaterialDesc {", declaration));
  EXPECT_TRUE(std::regex_search("enum class Tissue : uint8_t {", declaration));
  EXPECT_FALSE(std::regex_search("struct MaterialTable {", declaration));
  EXPECT_TRUE(std::regex_search("class ReplayDevice : public Device {", device_class()));
  EXPECT_TRUE(std::regex_search("class MouseDevice final : public Device {", device_class()));
  EXPECT_FALSE(std::regex_search("struct DeviceOptions {", device_class()));
  EXPECT_FALSE(std::regex_search("class UdpDevice : public DeviceBase {", device_class()));
}

}  // namespace
}  // namespace cariesim
