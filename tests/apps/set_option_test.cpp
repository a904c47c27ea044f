// `--set KEY=VALUE` (docs/cli.md, docs/scene-format.md "Overrides") on sim, servo, experiment and
// study run: the value reaches the scene, and a bad key or value is refused with the scene file's
// message, located at the override, before anything runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "apps/apps_support.hpp"
#include "support/files.hpp"

namespace cariesim::test {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

class SetOption : public ScratchTest {
 protected:
  SetOption() : ScratchTest("cariesim_set_") {}

  CommandResult run(const std::string& args) const {
    return run_cariesim(args, "CARIESIM_CACHE_DIR='" + (dir_ / "cache").string() + "'");
  }

  // A 0.1 s trajectory pressing 0.4 mm into the friction block's top (z = 0) and sliding along x.
  fs::path press_trajectory() const {
    const fs::path file = dir_ / "press.csv";
    std::ofstream out(file);
    out << "t,px,py,pz,qw,qx,qy,qz\n0,-20,0,1,1,0,0,0\n0.04,-20,0,-0.4,1,0,0,0\n0.1,-19,0,-0.4,1,0,0,0\n";
    return file;
  }

  // fz of a sim output's row at `t` (s).
  static double fz_at(const fs::path& csv, double t) {
    std::istringstream in(read_text(csv));
    std::string line, header;
    std::getline(in, header);
    while (std::getline(in, line)) {
      std::vector<std::string> cells;
      std::istringstream row(line);
      for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
      if (cells.size() > 17 && std::abs(std::stod(cells[0]) - t) < 1e-6)
        return std::stod(cells[17]);  // t, 7 haptic, 7 graphic, fx, fy, fz
    }
    ADD_FAILURE() << csv << " has no row at t = " << t;
    return 0.0;
  }
};

TEST_F(SetOption, SimRunsTheOverriddenScene) {
  const fs::path traj = press_trajectory();
  const std::string base = "sim --scene friction-block --trajectory '" + traj.string() + "' --quiet --out '";
  CommandResult r = run(base + (dir_ / "plain.csv").string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  // The carious top's sliding stiffness, doubled and halved: the pressing force changes with it.
  r = run(base + (dir_ / "stiff.csv").string() + "' --set lesions[0].material.stiffness=2.0");
  ASSERT_EQ(r.status, 0) << r.err;
  r = run(base + (dir_ / "soft.csv").string() + "' --set 'lesions[0].material.stiffness = 0.5'");
  ASSERT_EQ(r.status, 0) << r.err;
  // At the end of the press (t = 0.04 s), before the slide: the stiffer top pushes back harder, the
  // softer one less (the slide's end depends also on whether the tip caught, docs/penetration.md).
  const double plain = fz_at(dir_ / "plain.csv", 0.04);
  const double stiff = fz_at(dir_ / "stiff.csv", 0.04);
  const double soft = fz_at(dir_ / "soft.csv", 0.04);
  EXPECT_GT(plain, 0.05);
  EXPECT_GT(stiff, 1.05 * plain);
  EXPECT_LT(soft, 0.95 * plain);
}

TEST_F(SetOption, BadOverridesAreRefusedWithTheFilesMessage) {
  const fs::path traj = press_trajectory();
  const std::string sim = "sim --scene friction-block --trajectory '" + traj.string() + "' --quiet --out '" +
                          (dir_ / "o.csv").string() + "' ";
  CommandResult r = run(sim + "--set lesions[0].material.f_p_star=-1");
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("builtin:friction-block (override lesions[0].material.f_p_star): "
                               "lesions[0].material.f_p_star: "));
  r = run(sim + "--set objects[0].materal.stiffness=2");
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("objects[0].materal: unknown key (did you mean 'material'?"));
  r = run(sim + "--set lesions[4].material.k_c=1");
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("lesions has 1 entry"));
  r = run(sim + "--set 'lesions[0].material.k_c'");  // no '=': refused as the option is read
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("expected KEY=VALUE"));
  EXPECT_FALSE(fs::exists(dir_ / "o.csv"));
  r = run("run friction-block --set 'a..b=1'");  // the window's command reads its --set the same way
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("character 3: expected a field name"));

  // The same override refused by servo, experiment and study run before they start.
  r = run("servo --scene friction-block --duration 0.1 --quiet --set lesions[0].material.f_p_star=-1");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("(override lesions[0].material.f_p_star): lesions[0].material.f_p_star: "));
  r = run("experiment friction --no-figures --quiet --out '" + (dir_ / "exp").string() +
          "' --set lesions[0].material.mu_s=9");
  EXPECT_NE(r.status, 0);
  EXPECT_THAT(r.err, HasSubstr("(override lesions[0].material.mu_s): lesions[0].material.mu_s: "));
}

TEST_F(SetOption, StudyTrialsRunTheOverriddenScene) {
  const fs::path answers = dir_ / "answers.yaml";
  std::ofstream(answers) << "trials:\n  - shapes: [square, circle, triangle]\n";
  const std::string study = (fs::path(CARIESIM_SOURCE_DIR) / "studies/examples/boundary-small.yaml").string();
  const std::string args = "study run '" + study + "' --participant P01 --answers '" + answers.string() +
                           "' --trials 1 --duration 0.05 --quiet --out '";
  CommandResult r = run(args + (dir_ / "bad.db").string() + "' --set device.max_force=-1");
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("(override device.max_force): device.max_force: "));

  r = run(args + (dir_ / "s.db").string() + "' --set device.max_force=2.5");
  ASSERT_EQ(r.status, 0) << r.err;
  // The trial's recording holds the running parameters: the device's force limit is the override's.
  fs::path recording;
  for (const auto& entry : fs::directory_iterator(dir_ / "s-recordings"))
    if (entry.path().extension() == ".db") recording = entry.path();
  ASSERT_FALSE(recording.empty());
  r = run("export '" + recording.string() + "' --quiet --out '" + (dir_ / "export").string() + "'");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_THAT(read_text(dir_ / "export" / "session.csv"), HasSubstr(R"(""max_force"":2.5,)"));
}

}  // namespace
}  // namespace cariesim::test
