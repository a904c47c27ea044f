// The house of docs/architecture.md, enforced: every `#include "cariesim/<module>/..."` (and every
// private `#include "<module>/..."`) in include/cariesim/, src/ and apps/ must follow an arrow the
// table below allows. The table is the drawing's: modules include only modules drawn below them,
// nothing points from device, record or render back up, and the experiments and training are two
// applications side by side (neither includes the other; the runtime includes neither). And no file
// outside a module (another module, a public header, bench/, apps/, another module's tests) includes
// its private headers (src/<module>/...). A failure names the file, the line and the forbidden arrow.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace cariesim {
namespace {

namespace fs = std::filesystem;

// The modules and what each may include (besides itself), bottom up as docs/architecture.md draws
// them. `servo` is the runtime; `apps` are the command line and the viewer.
const std::map<std::string, std::set<std::string>>& allowed() {
  static const std::map<std::string, std::set<std::string>> table = [] {
    std::map<std::string, std::set<std::string>> t;
    t["common"] = {};
    t["io"] = {"common"};            // files, documents, databases and processes from elsewhere
    t["device"] = {"common", "io"};  // a leaf: math, io and its own types only
    t["geometry"] = {"common", "io"};
    t["spheretree"] = {"common", "io", "geometry"};
    t["collision"] = {"common", "io", "geometry", "spheretree"};
    t["solver"] = {"common"};
    t["render"] = {"common", "io", "device", "geometry", "spheretree", "collision", "solver"};
    // Above the step the house forks: the model builder (scene) and the record each stand on it; the
    // runtime (servo) on both; the two applications side by side, the experiments on the scene and
    // training on the runtime; the apps on everything.
    const auto above = [&t](const std::string& base, std::initializer_list<const char*> more) {
      std::set<std::string> out = t[base];
      out.insert(base);
      for (const char* m : more) {
        out.insert(t[m].begin(), t[m].end());
        out.insert(m);
      }
      return out;
    };
    t["scene"] = above("render", {});
    t["record"] = above("render", {});
    t["servo"] = above("record", {"scene"});
    t["experiment"] = above("scene", {});
    t["training"] = above("servo", {});
    t["apps"] = above("training", {"experiment"});
    return t;
  }();
  return table;
}

// One forbidden include.
struct Violation {
  std::string file;
  int line = 0;
  std::string from, to, text;
};

// The module an include names, or "" when it names none: "cariesim/<module>/..." (public) or
// "<module>/..." for a known module (a module's private header under src/).
std::string included_module(const std::string& path) {
  std::string rest = path;
  if (rest.rfind("cariesim/", 0) == 0) rest = rest.substr(9);
  const std::size_t slash = rest.find('/');
  if (slash == std::string::npos) return "";
  const std::string module = rest.substr(0, slash);
  if (allowed().count(module) == 0) return path.rfind("cariesim/", 0) == 0 ? module : "";
  return module;
}

// The path an `#include "x"` or `#include <x>` line names (spaces allowed after the '#'), or "".
std::string included_path(const std::string& line) {
  std::size_t p = line.find_first_not_of(" \t");
  if (p == std::string::npos || line[p] != '#') return "";
  p = line.find_first_not_of(" \t", p + 1);
  if (p == std::string::npos || line.compare(p, 7, "include") != 0) return "";
  p = line.find_first_of("\"<", p + 7);
  if (p == std::string::npos) return "";
  const std::size_t end = line.find(line[p] == '"' ? '"' : '>', p + 1);
  if (end == std::string::npos) return "";
  return line.substr(p + 1, end - p - 1);
}

// Checks one file's text as part of `module`; appends what breaks the table.
void check_text(const std::string& file, const std::string& module, const std::string& text,
                std::vector<Violation>& out) {
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    const std::string target = included_module(included_path(line));
    if (target.empty() || target == module) continue;
    const auto rule = allowed().find(module);
    if (rule == allowed().end() || rule->second.count(target) == 0)
      out.push_back({file, number, module, target, line});
  }
}

// The module a file belongs to: include/cariesim/<m>/..., src/<m>/..., apps/... ("" for none).
std::string file_module(const fs::path& relative) {
  auto it = relative.begin();
  if (it == relative.end()) return "";
  const std::string top = it->string();
  if (top == "apps") return "apps";
  if (top == "include" && ++it != relative.end() && it->string() == "cariesim" && ++it != relative.end())
    return it->string();
  if (top == "src" && ++it != relative.end()) return it->string();
  return "";
}

bool is_source(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".hpp" || ext == ".cpp" || ext == ".h" || ext == ".cc";
}

// Checks one file of bench/, apps/ or tests/ owned by `owner` (the module a test folder tests, or
// "bench", "apps"): an include of a module's private header (src/<module>/..., found under `root`)
// other than the owner's own is appended, as an arrow to "<module> (private)".
void check_private(const fs::path& root, const std::string& file, const std::string& owner,
                   const std::string& text, std::vector<Violation>& out) {
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    const std::string path = included_path(line);
    if (path.rfind("cariesim/", 0) == 0) continue;  // a public header
    const std::string module = included_module(path);
    if (module.empty() || module == owner || !fs::is_regular_file(root / "src" / path)) continue;
    out.push_back({file, number, owner, module + " (private)", line});
  }
}

std::string describe(const std::vector<Violation>& violations) {
  std::string text;
  for (const Violation& v : violations)
    text += v.file + ":" + std::to_string(v.line) + ": " + v.from + " -> " + v.to +
            " is not an arrow of docs/architecture.md (" + v.text + ")\n";
  return text;
}

TEST(IncludeGraph, TheCheckerFindsAForbiddenArrow) {
  // The checker itself: an arrow back up from each of device, record and render is reported with
  // its line; allowed arrows, std headers and a module's own headers are not.
  std::vector<Violation> v;
  check_text(
      "device/x.hpp", "device",
      "#include <vector>\n#include \"cariesim/common/math.hpp\"\n# include \"cariesim/render/step.hpp\"\n",
      v);
  check_text("record/x.cpp", "record", "#include \"cariesim/device/device.hpp\"\n#include \"servo/x.hpp\"\n",
             v);
  check_text("render/x.cpp", "render",
             "#include \"render/internal.hpp\"\n#include <cariesim/scene/scene.hpp>\n", v);
  ASSERT_EQ(v.size(), 3u) << describe(v);
  EXPECT_EQ(v[0].line, 3);
  EXPECT_EQ(v[0].to, "render");
  EXPECT_EQ(v[1].from, "record");
  EXPECT_EQ(v[1].to, "servo");
  EXPECT_EQ(v[2].to, "scene");
  // An unknown public module is an arrow nowhere in the house.
  v.clear();
  check_text("apps/x.cpp", "apps", "#include \"cariesim/gui/window.hpp\"\n", v);
  EXPECT_EQ(v.size(), 1u);
}

TEST(IncludeGraph, TheApplicationsStandSideBySide) {
  // The runtime includes no experiment (it once did, for the JSON writer), the experiments include
  // no runtime or training, training includes no experiment; the apps include both.
  std::vector<Violation> v;
  check_text("src/servo/x.cpp", "servo", "#include \"cariesim/experiment/experiments.hpp\"\n", v);
  check_text("src/experiment/x.cpp", "experiment", "#include \"cariesim/servo/servo.hpp\"\n", v);
  check_text("src/experiment/x.cpp", "experiment", "#include \"cariesim/training/study.hpp\"\n", v);
  check_text("src/training/x.cpp", "training", "#include \"cariesim/experiment/experiments.hpp\"\n", v);
  EXPECT_EQ(v.size(), 4u) << describe(v);
  v.clear();
  check_text("apps/x.cpp", "apps",
             "#include \"cariesim/experiment/experiments.hpp\"\n#include \"cariesim/training/study.hpp\"\n",
             v);
  check_text("src/servo/x.cpp", "servo",
             "#include \"cariesim/scene/scene.hpp\"\n#include \"cariesim/record/recorder.hpp\"\n", v);
  EXPECT_TRUE(v.empty()) << describe(v);
}

TEST(IncludeGraph, EveryIncludeFollowsTheHouse) {
  // Every public header, every private source and every app file, by module.
  const fs::path root = CARIESIM_SOURCE_DIR;
  std::vector<Violation> violations;
  std::set<std::string> seen;
  int files = 0;
  for (const char* top : {"include/cariesim", "src", "apps"}) {
    ASSERT_TRUE(fs::is_directory(root / top)) << (root / top);
    for (const auto& entry : fs::recursive_directory_iterator(root / top)) {
      if (!entry.is_regular_file() || !is_source(entry.path())) continue;
      const fs::path relative = fs::relative(entry.path(), root);
      const std::string module = file_module(relative);
      if (module.empty()) continue;  // e.g. a file directly under src/
      seen.insert(module);
      ++files;
      // A folder that is no module of the house is a failure too: draw it first.
      if (allowed().count(module) == 0) {
        ADD_FAILURE() << relative.string() << ": module '" << module << "' is not in docs/architecture.md";
        continue;
      }
      std::ifstream in(entry.path(), std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      check_text(relative.string(), module, text.str(), violations);
    }
  }
  EXPECT_TRUE(violations.empty()) << describe(violations);
  // The scan saw the tree (a wrong root would pass vacuously).
  EXPECT_GT(files, 100);
  for (const char* module : {"common", "io", "device", "render", "record", "servo", "apps"})
    EXPECT_TRUE(seen.count(module)) << module;
}

TEST(IncludeGraph, TheCheckerFindsAPrivateHeaderIncludedFromOutside) {
  // A bench, an app or another module's test including a module's private header is reported with
  // its line; the module's own tests, public headers and test support headers (not under src/) are not.
  const fs::path root = CARIESIM_SOURCE_DIR;
  const std::string text =
      "#include \"cariesim/render/step.hpp\"\n#include \"render/state_impl.hpp\"\n"
      "#include \"training/study_db_support.hpp\"\n# include <experiment/oral.hpp>\n";
  std::vector<Violation> v;
  check_private(root, "bench/x_bench.cpp", "bench", text, v);
  ASSERT_EQ(v.size(), 2u) << describe(v);
  EXPECT_EQ(v[0].line, 2);
  EXPECT_EQ(v[0].to, "render (private)");
  EXPECT_EQ(v[1].line, 4);
  EXPECT_EQ(v[1].to, "experiment (private)");
  v.clear();
  check_private(root, "tests/render/x_test.cpp", "render", "#include \"render/state_impl.hpp\"\n", v);
  EXPECT_TRUE(v.empty()) << describe(v);
}

TEST(IncludeGraph, NoFileIncludesAnotherModulesPrivateHeader) {
  // What another module, a public header, bench/, apps/, python/ or another module's tests use of a module is
  // its public API (include/cariesim/); a module's private headers (src/<module>/) serve its own code
  // and its own tests. (src/ is on no other target's include path; this also catches a module that
  // reaches a neighbour's private header through its own.)
  const fs::path root = CARIESIM_SOURCE_DIR;
  std::vector<Violation> violations;
  int files = 0;
  for (const char* top : {"src", "include/cariesim", "bench", "apps", "python", "tests"}) {
    ASSERT_TRUE(fs::is_directory(root / top)) << (root / top);
    for (const auto& entry : fs::recursive_directory_iterator(root / top)) {
      if (!entry.is_regular_file() || !is_source(entry.path())) continue;
      const fs::path relative = fs::relative(entry.path(), root);
      // src/<module>/... and tests/<module>/... belong to that module; public headers, bench/ and
      // apps/ to none.
      std::string owner = top;
      if (owner == "tests" || owner == "src") {
        auto it = relative.begin();
        owner = ++it != relative.end() ? it->string() : "";
      }
      ++files;
      std::ifstream in(entry.path(), std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      check_private(root, relative.string(), owner, text.str(), violations);
    }
  }
  EXPECT_TRUE(violations.empty()) << describe(violations);
  EXPECT_GT(files, 100);  // the scan saw the tree
}

TEST(IncludeGraph, EveryPublicHeaderServesOutsideItsModule) {
  // A public header (include/cariesim/<module>/) is there for another module, the apps, the
  // benchmarks or the examples; one that only its own module and its own tests include is private
  // and lives in src/<module>/ (docs/architecture.md, "Public surface").
  const fs::path root = CARIESIM_SOURCE_DIR;
  std::map<std::string, std::string> users;  // "cariesim/<module>/x.hpp" -> a file outside <module>
  for (const auto& entry : fs::recursive_directory_iterator(root / "include/cariesim")) {
    if (entry.is_regular_file() && is_source(entry.path()))
      users[fs::relative(entry.path(), root / "include").generic_string()];
  }
  ASSERT_GT(users.size(), 20u);  // the scan saw the headers
  for (const char* top : {"src", "include/cariesim", "bench", "apps", "python", "examples", "tests"}) {
    for (const auto& entry : fs::recursive_directory_iterator(root / top)) {
      if (!entry.is_regular_file() || !is_source(entry.path())) continue;
      const fs::path relative = fs::relative(entry.path(), root);
      // The module a file speaks for: src/<m>, tests/<m>, include/cariesim/<m>; bench/, apps/ and
      // examples/ for none.
      std::string owner = file_module(relative);
      if (relative.begin()->string() == "tests") owner = std::next(relative.begin())->string();
      if (owner == "apps") owner.clear();
      std::ifstream in(entry.path(), std::ios::binary);
      std::string line;
      while (std::getline(in, line)) {
        const std::string path = included_path(line);
        const auto it = users.find(path);
        if (it != users.end() && it->second.empty() && included_module(path) != owner)
          it->second = relative.generic_string();
      }
    }
  }
  for (const auto& [header, user] : users)
    EXPECT_FALSE(user.empty()) << "include/" << header << " is included only by its own module and its "
                               << "own tests: move it to src/ (docs/architecture.md)";
}

}  // namespace
}  // namespace cariesim
