// The real `cariesim run` under Xvfb (software OpenGL): the viewer starts on every built-in scene, a
// scripted device brings the tool onto a tooth or block, and the screenshot shows the touched
// tissue, the tool and the panel, checked with pixel statistics in the regions the status file
// names (not a golden image), while the UI reads "sliding" and a non-zero force. The screenshots
// stay in the build folder as artefacts: test-artifacts/viewer/<scene>.png (+ .json, .log).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "cariesim/scene/scene.hpp"
#include "cariesim/servo/servo.hpp"
#include "support/command.hpp"
#include "support/files.hpp"
#include "viewer_support.hpp"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// s of servo time before the screenshot: the trajectories press from t = 2.5 s on.
constexpr double kExitAfter = 4.0;

using cariesim::test::read_text;

using cariesim::test::have_xvfb;
using cariesim::test::Image;
using cariesim::test::load_png;
using cariesim::test::run_under_xvfb;
using cariesim::test::RunResult;

fs::path artefacts() { return cariesim::test::viewer_artefacts(); }

// The status file flattened by Python's JSON parser into "key value..." lines.
struct Status {
  std::map<std::string, std::string> text;            // string fields
  std::map<std::string, std::vector<double>> number;  // numbers and number arrays
  std::vector<std::vector<double>> tool_points;       // px
};

Status read_status(const fs::path& json) {
  const fs::path script = json.string() + ".py", flat = json.string() + ".txt";
  std::ofstream(script) << R"(import json, sys
d = json.load(open(sys.argv[1]))
for k in ("scene", "device", "state", "camera"):
    print("T", k, d[k])
for k in ("force_norm", "rendered_force_norm", "depth", "t", "width", "height"):
    print("N", k, d[k])
for k in ("cycles", "overruns", "work_budget", "standby_cycles", "spin_us"):
    print("N", k, d["timing"][k])
print("N background", *d["background"])
print("N tool_color", *d["tool_color"])
p = d["panel"]; print("N panel", p["x"], p["y"], p["w"], p["h"]); print("N scroll_max", p.get("scroll_max", 0))
v = d["view"]; print("N view", v["x"], v["y"], v["w"], v["h"])
if d["tip"] is not None: print("N tip", *d["tip"])
for q in d["tool_points"]: print("P", *q)
t = d["touched"]
if t is not None:
    print("T touched", t["object"]); print("T touched_tissue", t["tissue"]); print("N touched_color", *t["color"])
)";
  const cariesim::test::CommandOutput c = cariesim::test::run_command({"python3", script.string(), json.string()});
  std::ofstream(flat, std::ios::binary) << c.out << c.err;
  EXPECT_EQ(c.status, 0) << c.out << c.err << "\n" << read_text(json);
  Status s;
  std::istringstream lines(read_text(flat));
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream in(line);
    std::string kind, key;
    in >> kind;
    if (kind == "P") {
      std::vector<double> p(2);
      in >> p[0] >> p[1];
      s.tool_points.push_back(p);
      continue;
    }
    in >> key;
    if (kind == "T") {
      std::string value;
      std::getline(in >> std::ws, value);
      s.text[key] = value;
    } else {
      double v;
      while (in >> v) s.number[key].push_back(v);
    }
  }
  return s;
}

double luminance(const unsigned char* p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

int channel_distance(const unsigned char* p, const std::vector<double>& c) {
  int d = 0;
  for (int k = 0; k < 3; ++k) d = std::max(d, static_cast<int>(std::abs(p[k] - c[k])));
  return d;
}

// Same hue family as `c` (chromaticity within 0.03, shading aside) and not the background.
bool like_color(const unsigned char* p, const std::vector<double>& c, const std::vector<double>& background) {
  const double sp = p[0] + p[1] + p[2], sc = c[0] + c[1] + c[2];
  if (sp < 60.0 || channel_distance(p, background) <= 12) return false;
  const double dr = p[0] / sp - c[0] / sc, dg = p[1] / sp - c[1] / sc;
  return std::hypot(dr, dg) < 0.03;
}

// Per-region statistics, printed for the report.
struct Stats {
  int pixels = 0;
  double mean_luminance = 0.0;
  double bright = 0.0;      // fraction with luminance > 170
  double background = 0.0;  // fraction within 12 of the background colour
  double like = 0.0;        // fraction in the colour family asked for
};

Stats region_stats(const Image& img, int x0, int y0, int x1, int y1, const std::vector<double>& background,
                   const std::vector<double>* like) {
  Stats s;
  x0 = std::clamp(x0, 0, img.w);
  x1 = std::clamp(x1, 0, img.w);
  y0 = std::clamp(y0, 0, img.h);
  y1 = std::clamp(y1, 0, img.h);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const unsigned char* p = img.at(x, y);
      ++s.pixels;
      const double l = luminance(p);
      s.mean_luminance += l;
      if (l > 170.0) s.bright += 1;
      if (channel_distance(p, background) <= 12) s.background += 1;
      if (like != nullptr && like_color(p, *like, background)) s.like += 1;
    }
  if (s.pixels > 0) {
    s.mean_luminance /= s.pixels;
    s.bright /= s.pixels;
    s.background /= s.pixels;
    s.like /= s.pixels;
  }
  return s;
}

std::string scene_test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string name = info.param;
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
}

class ViewerXvfb : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (!have_xvfb())
      GTEST_SKIP() << "xvfb-run is not installed (Debian package xvfb; scripts/setup installs it)";
  }
};

// Every built-in scene: a scripted touch, then the screenshot's regions and the UI's state.
TEST_P(ViewerXvfb, ScriptedTouchShowsToothToolAndPanel) {
  const std::string scene = GetParam();
  const fs::path trajectory =
      fs::path(CARIESIM_SOURCE_DIR) / "scenes" / "trajectories" / ("viewer-touch-" + scene + ".csv");
  ASSERT_TRUE(fs::exists(trajectory)) << trajectory;
  const fs::path png = artefacts() / (scene + ".png"), json = artefacts() / (scene + ".json");
  fs::remove(png);
  fs::remove(json);
  const RunResult r = run_under_xvfb("run --scene " + scene + " --device 'scripted:" + trajectory.string() +
                                         "' --no-realtime --exit-after " + std::to_string(kExitAfter) +
                                         " --screenshot '" + png.string() + "'",
                                     scene);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("state sliding"));
  EXPECT_THAT(r.out, HasSubstr("step time (us): p50"));
  ASSERT_TRUE(fs::exists(png) && fs::exists(json)) << r.err;

  // The UI's readouts at the screenshot: sliding with a force, the servo clock past exit_after.
  const Status status = read_status(json);
  EXPECT_EQ(status.text.at("scene"), scene);
  EXPECT_EQ(status.text.at("state"), "sliding");
  EXPECT_GT(status.number.at("force_norm").at(0), 0.05);
  EXPECT_GE(status.number.at("t").at(0), kExitAfter);
  // The servo loop's counters: it ran, and an ordinary touch never reached the step's work budget.
  EXPECT_GT(status.number.at("cycles").at(0), 1000.0);
  EXPECT_EQ(status.number.at("work_budget").at(0), 0.0);
  // Cycles the standby thread ran for a servo thread woken late (issue #11), at most all of them.
  EXPECT_GE(status.number.at("standby_cycles").at(0), 0.0);
  EXPECT_LE(status.number.at("standby_cycles").at(0), status.number.at("cycles").at(0));
  EXPECT_EQ(status.number.at("spin_us").at(0), cariesim::kDefaultSpinUs);  // polled before each deadline
  EXPECT_THAT(r.out, HasSubstr("polls the last 150 us of each wait"));

  // The image is the window's framebuffer.
  const Image img = load_png(png);
  ASSERT_NE(img.data, nullptr) << png;
  EXPECT_EQ(img.w, static_cast<int>(status.number.at("width").at(0)));
  EXPECT_EQ(img.h, static_cast<int>(status.number.at("height").at(0)));
  const std::vector<double>& bg = status.number.at("background");

  // The panel: ImGui's dark window with light text, not the 3-D background.
  const std::vector<double>& p = status.number.at("panel");
  const Stats panel =
      region_stats(img, static_cast<int>(p[0]) + 4, static_cast<int>(p[1]) + 4,
                   static_cast<int>(p[0] + p[2]) - 4, static_cast<int>(p[1] + p[3]) - 4, bg, nullptr);
  std::printf("[%s] panel: %d px, mean luminance %.1f, text (bright) %.3f, background-coloured %.3f\n",
              scene.c_str(), panel.pixels, panel.mean_luminance, panel.bright, panel.background);
  EXPECT_GT(panel.pixels, 100000);
  EXPECT_LT(panel.mean_luminance, 60.0);
  EXPECT_GT(panel.bright, 0.005) << "the panel shows text";
  EXPECT_LT(panel.background, 0.2);

  // Around the tool tip: the touched tooth or block, in its tissue's colour.
  ASSERT_TRUE(status.number.count("tip")) << "the tip is in view";
  ASSERT_TRUE(status.number.count("touched_color")) << "the tool touches something";
  const std::vector<double>& tip = status.number.at("tip");
  const std::vector<double>& color = status.number.at("touched_color");
  const Stats tooth = region_stats(img, static_cast<int>(tip[0]) - 30, static_cast<int>(tip[1]) - 30,
                                   static_cast<int>(tip[0]) + 31, static_cast<int>(tip[1]) + 31, bg, &color);
  std::printf("[%s] around the tip (%s, %s): %d px, %.3f in its colour, %.3f background\n", scene.c_str(),
              status.text.at("touched").c_str(), status.text.at("touched_tissue").c_str(), tooth.pixels,
              tooth.like, tooth.background);
  EXPECT_GT(tooth.like, 0.3) << "the " << status.text.at("touched_tissue") << " colour around the tip";
  if (scene == "oral-cavity") {
    EXPECT_EQ(status.text.at("touched_tissue"), "enamel");
  }

  // Along the tool: around points on its centre line, the 7x7 px window is not all background. The
  // shaft can be 2 px wide at this zoom, so a line crossing the window (at least 10 % of it) counts.
  int in_view = 0, drawn = 0;
  for (const auto& q : status.tool_points) {
    ++in_view;
    const Stats s = region_stats(img, static_cast<int>(q[0]) - 3, static_cast<int>(q[1]) - 3,
                                 static_cast<int>(q[0]) + 4, static_cast<int>(q[1]) + 4, bg, nullptr);
    if (s.background < 0.9) ++drawn;
  }
  std::printf("[%s] tool: %d of %d centre-line points in view are drawn\n", scene.c_str(), drawn, in_view);
  EXPECT_GE(in_view, 2) << "the tip and at least 10 mm of the tool are in view";
  EXPECT_GE(drawn, (in_view * 3 + 3) / 4);
}

INSTANTIATE_TEST_SUITE_P(BuiltinScenes, ViewerXvfb, ::testing::ValuesIn(cariesim::builtin_scene_names()),
                         scene_test_name);

// The clinician's views (issue #12): each camera preset looks at the explorer's tip from its side; the
// tip and the working end are in view and drawn (the working end over everything: neither a tooth
// nor the handle hides it), the panel says which view it is.
class ViewerPreset : public ::testing::TestWithParam<std::string> {};

TEST_P(ViewerPreset, LooksAtTheTipFromItsSide) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  const std::string view = GetParam();
  const fs::path trajectory =
      fs::path(CARIESIM_SOURCE_DIR) / "scenes" / "trajectories" / "viewer-touch-oral-cavity.csv";
  const fs::path png = artefacts() / ("view-" + view + ".png"),
                 json = artefacts() / ("view-" + view + ".json");
  fs::remove(png);
  fs::remove(json);
  const RunResult r = run_under_xvfb("run --scene oral-cavity --device 'scripted:" + trajectory.string() +
                                         "' --view " + view + " --no-realtime --exit-after " +
                                         std::to_string(kExitAfter) + " --screenshot '" + png.string() + "'",
                                     "view-" + view);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const Status status = read_status(json);
  EXPECT_EQ(status.text.at("camera"), view);
  ASSERT_TRUE(status.number.count("tip")) << "the tip is in view";
  // The camera follows the tip: it stays near the middle of the 3-D view.
  const std::vector<double>& tip = status.number.at("tip");
  const std::vector<double>& v = status.number.at("view");
  EXPECT_NEAR(tip[0], v[0] + 0.5 * v[2], 0.1 * v[2]);
  EXPECT_NEAR(tip[1], v[1] + 0.5 * v[3], 0.1 * v[3]);
  // The tip's surroundings are drawn (not background), and the working end's first 10 mm are in view.
  const Image img = load_png(png);
  ASSERT_NE(img.data, nullptr) << png;
  const Stats around = region_stats(img, static_cast<int>(tip[0]) - 3, static_cast<int>(tip[1]) - 3,
                                    static_cast<int>(tip[0]) + 4, static_cast<int>(tip[1]) + 4,
                                    status.number.at("background"), nullptr);
  EXPECT_LT(around.background, 0.5);
  EXPECT_GE(status.tool_points.size(), 2u) << "the tip and at least 10 mm of the tool are in view";
}

INSTANTIATE_TEST_SUITE_P(Presets, ViewerPreset,
                         ::testing::Values("occlusal", "buccal", "lingual", "operator"));

// Another window size: the 3-D view and the docked panel follow it, and the panel, taller than a
// 500 px window, scrolls.
TEST(ViewerXvfbSize, ViewAndPanelFollowTheWindowAndThePanelScrolls) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  const fs::path png = artefacts() / "size-900x500.png";
  const RunResult r = run_under_xvfb(
      "run --scene oral-cavity --device null --size 900 500 --no-realtime --exit-after 1 --screenshot '" +
          png.string() + "'",
      "size-900x500");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const Status status = read_status(artefacts() / "size-900x500.json");
  EXPECT_EQ(status.number.at("width").at(0), 900.0);
  EXPECT_EQ(status.number.at("height").at(0), 500.0);
  const std::vector<double>& p = status.number.at("panel");
  const std::vector<double>& v = status.number.at("view");
  EXPECT_NEAR(p[0] + p[2], 900.0, 1.0) << "the panel docks at the right edge";
  EXPECT_NEAR(p[3], 500.0, 1.0) << "the panel takes the window's height";
  EXPECT_NEAR(v[2], 900.0 - p[2], 1.0) << "the view takes the rest";
  EXPECT_GT(status.number.at("scroll_max").at(0), 0.0) << "the panel's content scrolls";
}

// The default: real-arch with the mouse device; the tool waits at its home, free.
TEST(ViewerXvfbDefault, MouseOnTheRealArch) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  const fs::path png = artefacts() / "default-mouse.png";
  const RunResult r = run_under_xvfb("run --no-realtime --exit-after 1.5 --screenshot '" + png.string() + "'",
                                     "default-mouse");
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const Status status = read_status(artefacts() / "default-mouse.json");
  EXPECT_EQ(status.text.at("scene"), "real-arch");
  EXPECT_EQ(status.text.at("device"), "mouse");
  EXPECT_EQ(status.text.at("state"), "free");
  EXPECT_THAT(r.out, HasSubstr("servo:"));
}

// Without a display `cariesim run` says so, names xvfb-run, and fails.
TEST(ViewerHeadless, NoDisplayIsAClearError) {
  const cariesim::test::CommandOutput c =
      cariesim::test::run_command({"env", "-u", "DISPLAY", "-u", "WAYLAND_DISPLAY", CARIESIM_EXE, "run"});
  EXPECT_EQ(c.status, 4) << c.how;
  const std::string text = c.err;
  EXPECT_THAT(text, HasSubstr("DISPLAY is not set"));
  EXPECT_THAT(text, HasSubstr("xvfb-run"));
}

// scripts/run without a display: it says so, runs the simulator under xvfb-run on the default scene
// with the mouse, and stops by itself with a screenshot in the build folder.
TEST(ScriptsRun, FallsBackToXvfbWithoutADisplay) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed";
  const fs::path build(CARIESIM_BINARY_DIR);
  const fs::path png = build / "run-xvfb.png", json = build / "run-xvfb.json";
  fs::remove(png);
  fs::remove(json);
  cariesim::io::ProcessOptions options;
  options.environment = {"CARIESIM_BUILD_DIR=" + build.string(), "CARIESIM_JOBS=1", "CARIESIM_XVFB_SECONDS=1.5",
                         "CARIESIM_CACHE_DIR=" + (build / "test-cache").string()};
  const cariesim::test::CommandOutput c = cariesim::test::run_command(
      {"env", "-u", "DISPLAY", "-u", "WAYLAND_DISPLAY", "timeout", "900",
       std::string(CARIESIM_SOURCE_DIR) + "/scripts/run"},
      options);
  const std::string log = c.err;
  ASSERT_EQ(c.status, 0) << c.how << "\n" << log << c.out;
  EXPECT_THAT(log, HasSubstr("no display"));
  EXPECT_THAT(log, HasSubstr("xvfb-run"));
  ASSERT_TRUE(fs::exists(png) && fs::exists(json)) << log;
  const Status s = read_status(json);
  EXPECT_EQ(s.text.at("scene"), "real-arch");
  EXPECT_EQ(s.text.at("device"), "mouse");
  EXPECT_GE(s.number.at("t").at(0), 1.5);
}

}  // namespace
