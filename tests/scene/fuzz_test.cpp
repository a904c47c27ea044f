#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/render/step.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

// Splits text into lines (keeping the newline).
std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    const std::size_t stop = end == std::string::npos ? text.size() : end + 1;
    lines.push_back(text.substr(start, stop - start));
    start = stop;
  }
  return lines;
}

// One random edit: delete, duplicate or replace a character or a line, or swap two lines.
std::string mutate(const std::string& text, std::mt19937_64& rng) {
  static const std::string kAlphabet = " \n\t:-[]{},#&*!|>'\"%@`0123456789.eE+-abcxyz_";
  std::string out = text;
  if (out.empty()) return "a";
  std::uniform_int_distribution<std::size_t> pick(0, out.size() - 1);
  std::uniform_int_distribution<std::size_t> letter(0, kAlphabet.size() - 1);
  switch (std::uniform_int_distribution<int>(0, 6)(rng)) {
    case 0:
      out.erase(pick(rng), 1);
      break;
    case 1: {
      const std::size_t at = pick(rng);
      out.insert(at, 1, out[at]);
      break;
    }
    case 2:
      out[pick(rng)] = kAlphabet[letter(rng)];
      break;
    case 3:
      out.insert(pick(rng), 1, kAlphabet[letter(rng)]);
      break;
    default: {
      std::vector<std::string> lines = lines_of(out);
      std::uniform_int_distribution<std::size_t> line(0, lines.size() - 1);
      const std::size_t a = line(rng);
      const std::size_t b = line(rng);
      const int op = std::uniform_int_distribution<int>(0, 2)(rng);
      if (op == 0) {
        lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(a));
      } else if (op == 1) {
        lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(a), lines[b]);
      } else {
        std::swap(lines[a], lines[b]);
      }
      out.clear();
      for (const auto& l : lines) out += l;
      break;
    }
  }
  return out;
}

// Random edits of the built-in scenes must parse or throw cariesim::Error: never crash, hang or throw
// anything else. Seeded, so a failure reproduces; bounded to a few seconds.
TEST(SceneParserFuzz, MutatedBuiltInsParseOrThrowError) {
  std::mt19937_64 rng(20160401);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(4);
  std::size_t parsed = 0;
  std::size_t rejected = 0;
  for (int round = 0; round < 4000 && std::chrono::steady_clock::now() < deadline; ++round) {
    for (const auto& name : builtin_scene_names()) {
      std::string text(builtin_scene_yaml(name));
      const int edits = std::uniform_int_distribution<int>(1, 4)(rng);
      for (int e = 0; e < edits; ++e) text = mutate(text, rng);
      try {
        (void)parse_scene(text, "fuzz.yaml");
        ++parsed;
      } catch (const Error& e) {
        // Every message is located.
        ASSERT_EQ(std::string(e.what()).rfind("fuzz.yaml:", 0), 0u) << e.what();
        ++rejected;
      } catch (const std::exception& e) {
        FAIL() << "round " << round << " (" << name << "): non-Error exception: " << e.what() << "\n" << text;
      } catch (...) {
        FAIL() << "round " << round << " (" << name << "): unknown exception\n" << text;
      }
    }
  }
  // Both outcomes occur: the mutations neither always break nor never break the scenes.
  EXPECT_GT(parsed, 0u);
  EXPECT_GT(rejected, 0u);
}

// The adversarial inputs of issue #14 (items 2, 9) stay answered: each is refused with a message
// located in the file, or parsed when it is valid (mu_d above mu_s is defined, docs/scene-format.md).
TEST(SceneParserFuzz, Issue14InputsAreRefusedWhereTheyAre) {
  const std::string block = "objects:\n  - name: b\n    shape: {type: cuboid, size: [4, 4, 4]}\n";
  const struct {
    std::string yaml;
    std::string message;  // empty: it parses
  } cases[] = {
      {block + "servo_rate: 20000\n", "fuzz.yaml:4:13: servo_rate: 20000 is out of range [100, 10000] Hz"},
      {block + "servo_rate: .nan\n", "fuzz.yaml:4:13: servo_rate"},
      {"objects:\n  - name: b\n    shape: {type: cuboid, size: [1e-6, 1, 1]}\n", "edge 1e-06 mm is below"},
      {"objects:\n  - name: b\n    shape: {type: cuboid, size: [0.02, 4, 4]}\n", "two level-set voxels"},
      {"objects:\n  - name: b\n    shape: {type: mesh, file: .}\n",
       "not a regular file (a folder), not a mesh file"},
      {block + "lesions:\n  - {name: l, object: b, placement: {at: [0, 0, 2], normal: [0, 0, 1]},\n"
               "     shape: {type: disk, size: 1, depth: 0.5}, material: {mu_s: 0.1, mu_d: 0.9}}\n",
       ""},
  };
  for (const auto& c : cases) {
    try {
      (void)parse_scene(c.yaml, "fuzz.yaml");
      EXPECT_TRUE(c.message.empty()) << "parsed:\n" << c.yaml;
    } catch (const Error& e) {
      EXPECT_FALSE(c.message.empty()) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind("fuzz.yaml:", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos) << e.what();
    }
  }
}

// Issue #14 item 10: valid but extreme parameters (a tool of the finest sphere chain and the thickest
// handle allowed, tissue of almost no stiffness, the whole tool pressed through it, the hand far off)
// made steps of several ms. The step's collision work is bounded (StepSettings::work_budget, in node
// pairs, docs/step.md): every step stays within it, says when it ran out, and stays finite and bounded.
TEST(SceneParserFuzz, Issue14ExtremeParametersStayWithinTheStepsWorkBudget) {
  const std::filesystem::path scene =
      std::filesystem::path(CARIESIM_SOURCE_DIR) / "scenes/examples/extreme-parameters.yaml";
  const Model m = build_model(load_scene(scene.string()));
  State s(m, m.tool_home);
  bool ran_out = false;
  int64_t most = 0;
  for (int i = 0; i < 60; ++i) {
    // The hand sinks 1 mm per step through the block and 20 mm beyond.
    Pose hand = m.tool_home;
    hand.p.z() -= std::min(1.0 * i, 28.0);
    const StepOutput out = step(m, s, HapticInput{hand, 0.001});
    EXPECT_LE(out.work, m.settings.work_budget) << i;
    ran_out = ran_out || (out.flags & kFlagWorkBudget);
    most = std::max(most, out.work);
    ASSERT_TRUE(out.force.allFinite() && out.torque.allFinite() && out.graphic.p.allFinite()) << i;
    EXPECT_LE(out.force.norm(), m.defaults.limits.max_force + 1e-9) << i;
    EXPECT_LE(out.torque.norm(), m.defaults.limits.max_torque + 1e-9) << i;
  }
  EXPECT_TRUE(ran_out) << "most work units in a step: " << most;
}

// Random edits of a trajectory file parse or throw cariesim::Error located in it; and the issue #14
// trajectory inputs (a byte order mark, non-unit quaternions, absurd times) are answered.
TEST(TrajectoryParserFuzz, MutatedTrajectoriesParseOrThrowError) {
  const std::string base =
      "t,px,py,pz,qw,qx,qy,qz\n0,-25,0,10,1,0,0,0\n0.5,-24,0,9,0.7071068,0,0.7071068,0\n1,-23,0,8,0,0,1,0\n";
  std::mt19937_64 rng(14);
  std::size_t parsed = 0, rejected = 0;
  for (int round = 0; round < 3000; ++round) {
    std::string text = base;
    const int edits = std::uniform_int_distribution<int>(1, 3)(rng);
    for (int e = 0; e < edits; ++e) text = mutate(text, rng);
    try {
      const Trajectory t = parse_trajectory_csv(text, "fuzz.csv");
      for (const Pose& p : t.pose) ASSERT_NEAR(p.q.norm(), 1.0, 1e-12) << text;
      ++parsed;
    } catch (const Error& e) {
      ASSERT_EQ(std::string(e.what()).rfind("fuzz.csv", 0), 0u) << e.what();
      ++rejected;
    } catch (const std::exception& e) {
      FAIL() << "round " << round << ": non-Error exception: " << e.what() << "\n" << text;
    }
  }
  EXPECT_GT(parsed, 0u);
  EXPECT_GT(rejected, 0u);
  EXPECT_EQ(parse_trajectory_csv("\xEF\xBB\xBF" + base, "fuzz.csv").t.size(), 3u);
  EXPECT_THROW(parse_trajectory_csv("t,px,py,pz,qw,qx,qy,qz\n0,0,0,0,3,0,0,0\n", "fuzz.csv"), Error);
  EXPECT_THROW(
      parse_trajectory_csv("t,px,py,pz,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1e400,0,0,0,1,0,0,0\n", "fuzz.csv"),
      Error);
}

}  // namespace
}  // namespace cariesim
