// Runs the cariesim binary (CARIESIM_EXE): `scene check` on good and bad scenes, `tree --json`.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "apps/apps_support.hpp"
#include "support/files.hpp"
#include "support/command.hpp"

namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

using Result = cariesim::test::CommandResult;

using cariesim::test::cube_stl;
using cariesim::test::read_text;

// A scratch folder per test, removed afterwards.
class CliTest : public cariesim::test::ScratchTest {
 protected:
  CliTest() : ScratchTest("cariesim_cli_") {}

  // Runs `cariesim ARGS` with the cache in the scratch folder; captures both streams.
  Result run(const std::string& args) const {
    return cariesim::test::run_cariesim(args, "CARIESIM_CACHE_DIR='" + (dir_ / "cache").string() + "'");
  }

  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path file = dir_ / name;
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }

  // Checks `json` with Python's strict parser and a script over `d`; returns the script's output.
  std::string python_json(const std::string& json, const std::string& script) const {
    const fs::path data = write("out.json", json);
    const fs::path code = write("check.py", "import json, sys\nd = json.load(open(sys.argv[1]))\n" + script);
    const cariesim::test::CommandOutput r = cariesim::test::run_command({"python3", code.string(), data.string()});
    EXPECT_EQ(r.status, 0) << r.how << "\n" << r.out << r.err << "\nJSON:\n" << json;
    return r.out + r.err;
  }
};

TEST_F(CliTest, SceneCheckAcceptsTheBuiltInsAndFiles) {
  const Result builtin = run("scene check oral-cavity");
  EXPECT_EQ(builtin.status, 0) << builtin.err;
  EXPECT_THAT(builtin.out, HasSubstr("ok: oral-cavity"));
  EXPECT_THAT(builtin.out, HasSubstr("lesion1"));

  const Result file =
      run("scene check '" + std::string(CARIESIM_SOURCE_DIR) + "/scenes/friction-block.yaml'");
  EXPECT_EQ(file.status, 0) << file.err;
  EXPECT_THAT(file.out, HasSubstr("ok: friction-block"));
}

TEST_F(CliTest, SceneCheckRejectsBadFilesWithLineAndColumn) {
  const std::string head = "objects:\n  - name: block\n    shape: {type: cuboid, size: [10, 20, 5]}\n";
  const fs::path wrong_type = write("wrong_type.yaml", head + "    pose: {position: 5}\n");
  Result r = run("scene check '" + wrong_type.string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err,
              HasSubstr("wrong_type.yaml:4:22: objects[0].pose.position: expected a sequence of 3 numbers"));

  const fs::path missing = write("missing.yaml", "objects:\n  - name: block\n");
  r = run("scene check '" + missing.string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("missing.yaml:2:5: objects[0].shape: missing required field"));

  const fs::path unknown = write("unknown.yaml", head + "    tissu: enamel\n");
  r = run("scene check '" + unknown.string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("unknown.yaml:4:5: objects[0].tissu: unknown key (did you mean 'tissue'?"));

  const fs::path bad_enum = write("bad_enum.yaml", head + "    kind: jelly\n");
  r = run("scene check '" + bad_enum.string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("bad_enum.yaml:4:11: objects[0].kind: unknown kind 'jelly'"));

  r = run("scene check no-such-scene");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("no-such-scene"));
}

TEST_F(CliTest, SceneCheckValidatesMeshContent) {
  write("empty.stl", "");
  const fs::path scene =
      write("scan.yaml", "objects:\n  - name: scan\n    shape: {type: mesh, file: empty.stl}\n");
  const Result r = run("scene check '" + scene.string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("scan.yaml:2:5: object 'scan'"));
  EXPECT_THAT(r.err, HasSubstr("empty.stl"));
}

TEST_F(CliTest, TreeJsonOnAMeshHasTheRequiredKeys) {
  const fs::path mesh = write("cube.stl", cube_stl(3.0));
  const Result r = run("tree '" + mesh.string() + "' --json --quiet --tolerance 0.05");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "--quiet prints no progress: " << r.err;
  const std::string checked = python_json(r.out, R"(
assert isinstance(d, dict)
assert isinstance(d["leaves"], int) and d["leaves"] > 0
assert isinstance(d["levels"], int) and d["levels"] >= 1
assert d["build_seconds"] >= 0
dev = d["deviation_mm"]
assert 0 <= dev["p50"] <= dev["p95"] <= dev["max"], dev
assert dev["samples"] >= 100000, dev
assert sum(d["nodes_per_level"]) >= d["leaves"]
print("leaves", d["leaves"])
)");
  EXPECT_THAT(checked, HasSubstr("leaves"));
}

TEST_F(CliTest, TreeOnASceneReportsEveryPartAndUsesTheCache) {
  write("cube.stl", cube_stl(4.0));
  const fs::path scene = write("small.yaml", R"(objects:
  - name: block
    shape: {type: mesh, file: cube.stl}
    tree: {tolerance: 0.05, max_radius: 0.8}
lesions:
  - name: pit
    object: block
    placement: {at: [2, 2, 4], normal: [0, 0, 1]}
    shape: {type: disk, size: 1.5, depth: 1.0}
    severity: severe
)");
  const std::string check_parts = R"(
names = [p["name"] for p in d["parts"]]
assert names == ["block/healthy", "block/pit"], names
for p in d["parts"]:
    assert p["leaves"] > 0 and p["levels"] >= 1
    assert p["deviation_mm"]["max"] >= p["deviation_mm"]["p95"]
healthy, pit = d["parts"]
assert "seam_deviation_mm" not in healthy, healthy
seam = pit["seam_deviation_mm"]
assert seam["band_mm"] == 0.5 and 0 <= seam["p50"] <= seam["p95"] <= seam["max"] and seam["samples"] > 0, seam
print("hit" if all(p["cache_hit"] for p in d["parts"]) else "cold")
)";
  const Result first = run("tree '" + scene.string() + "' --json");
  ASSERT_EQ(first.status, 0) << first.err;
  EXPECT_FALSE(first.err.empty()) << "progress goes to stderr";
  EXPECT_THAT(python_json(first.out, check_parts), HasSubstr("cold"));
  const Result second = run("tree '" + scene.string() + "' --json --quiet");
  ASSERT_EQ(second.status, 0) << second.err;
  EXPECT_THAT(python_json(second.out, check_parts), HasSubstr("hit"));
  const Result fast = run("tree '" + scene.string() + "' --json --quiet --no-deviation");
  ASSERT_EQ(fast.status, 0) << fast.err;
  EXPECT_THAT(python_json(fast.out, R"(
assert all("deviation_mm" not in p and "seam_deviation_mm" not in p and p["cache_hit"] and p["leaves"] > 0
           for p in d["parts"]), d
print("no deviation")
)"),
              HasSubstr("no deviation"));
  const Result text = run("tree '" + scene.string() + "' --quiet --no-cache");
  ASSERT_EQ(text.status, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("block/pit"));
  EXPECT_THAT(text.out, HasSubstr("deviation mm: p50"));
  EXPECT_THAT(text.out, HasSubstr("seam deviation mm (all parts, +/-0.5 mm around the border): p50"));
}

TEST_F(CliTest, TreeRejectsABadMesh) {
  const fs::path mesh = write("broken.stl", "solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n");
  const Result r = run("tree '" + mesh.string() + "' --quiet --no-cache");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("broken.stl"));
}

}  // namespace
