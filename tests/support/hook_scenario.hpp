#pragma once
// The hook of paper §4.2.1 / Fig. 12 on `boundary-square`, as `cariesim experiment boundary` runs it
// (stiff_out_of_soft): the tip pressed 0.59 mm into soft caries (0.1 N/mm) is dragged at 10 mm/s
// across the border onto firm healthy tissue (50 N/mm) and catches there while the hand goes on
// 10 mm. Shared by the render test of the release and the servo test of the bound.
#include <cmath>
#include <numbers>

#include "cariesim/common/trajectory.hpp"
#include "cariesim/experiment/experiments.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim::test {

struct HookScenario {
  Model model;
  Params params;         ///< caries 0.1 N/mm, healthy 50 N/mm
  double border = 0;     ///< mm, world x of the lesion's border on the line of the drag
  double press_z = 0;    ///< mm, world z of the hand's tip while pressing
  Quat q;                ///< the explorer leaning back against the motion (toward +x)
  double y = 0;          ///< mm, world y of the drag line
  double hooked_at = 0;  ///< s, when the hand has gone 10 mm past the border
};

inline HookScenario hook_scenario() {
  HookScenario h{build_model(load_scene("boundary-square")), {}, 0, 0, {}, 0, 0};
  const LesionModel& lesion = h.model.lesions.front();
  const Vec3 c = lesion.shape.center;
  h.border = lesion_border_x(lesion.shape, c.z(), c.y());
  h.y = c.y();
  h.press_z = c.z() + h.model.tool.tip_radius - 0.59;
  h.params = h.model.defaults;
  for (Material& m : h.params.materials) m.stiffness = m.lesion == 0 ? 0.1 : 50.0;
  // Moving toward -x: the home posture turned half a revolution about the vertical.
  h.q = (Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitZ())) * h.model.tool_home.q).normalized();
  return h;
}

/// From 2 mm above the caries 10 mm inside the border: press, drag 20 mm at 10 mm/s to 10 mm past the
/// border, hold `hold` s; then lift the hand by `lift` mm in `lift_time` s and hold 0.3 s.
inline Trajectory hook_trajectory(HookScenario& h, double hold, double lift, double lift_time) {
  const auto at = [&](double x, double z) { return Pose{Vec3(x, h.y, z), h.q}; };
  const double x0 = h.border + 10.0, x1 = h.border - 10.0;
  Trajectory t;
  t.add(0.0, at(x0, h.press_z + 2.6));
  t.add(0.5, at(x0, h.press_z));
  t.add(0.8, at(x0, h.press_z));
  t.add(2.8, at(x1, h.press_z));
  h.hooked_at = 2.8;
  t.add(2.8 + hold, at(x1, h.press_z));
  t.add(2.8 + hold + lift_time, at(x1, h.press_z + lift));
  t.add(3.1 + hold + lift_time, at(x1, h.press_z + lift));
  return t;
}

}  // namespace cariesim::test
