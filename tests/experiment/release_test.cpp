// A tool that lags behind the hand still lets go of its friction anchors (issue #11's servo trace). The
// friction cone used to be decided only in a sub-step whose motion ended inside its bounds; on
// scenes/trajectories/servo-touch-46.csv at 4 kHz the tool, after the firm press in 46's fossa, lagged
// in every sub-step of every cycle, kept its anchors and stayed pinned there for 3 s while the hand
// rose out of the fossa and moved 2.9 mm away, pulling at up to 2.9 N.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "cariesim/device/trajectory_csv.hpp"
#include "cariesim/experiment/simulate.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {
namespace {

TEST(Release, AfterTheFirmPressTheRisingHandFreesTheTool) {
  const Model model = build_model(load_scene("oral-cavity"));
  const Trajectory path =
      load_trajectory_csv(std::string(CARIESIM_SOURCE_DIR) + "/scenes/trajectories/servo-touch-46.csv");
  // The press is deepest at 4.0 s (the hand 1.7 mm below the fossa's floor) and the hand is back
  // above the floor by 4.7 s; from 5.0 s it moves up and across toward the crown's far side, which
  // it reaches after 5.6 s.
  double worst = 0.0, moved = 0.0;
  std::optional<Vec3> at_press_end;  // mm, the graphic tool once the press has ended (4.6 s)
  for (const SimSample& s : simulate(model, path, 4000.0)) {
    if (s.t > 4.6 && !at_press_end) at_press_end = s.out.graphic.p;
    if (s.t < 5.1 || s.t > 5.6) continue;
    worst = std::max(worst, s.out.force.norm());
    moved = std::max(moved, (s.out.graphic.p - *at_press_end).norm());
  }
  EXPECT_LT(worst, 0.5) << "N: the tool is still held in the fossa";
  EXPECT_GT(moved, 0.5) << "mm: the tool did not follow the hand out of the fossa";
}

}  // namespace
}  // namespace cariesim
