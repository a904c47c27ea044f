// Paper §4.2.1, Fig. 12: the tangential force when the probe slides across the boundary between a
// non-frictional (healthy) and a frictional (carious) region of a cube, both 1 N/mm; and with a large
// stiffness difference, where the tip sunk in the soft caries catches ("hooks") at the firmer wall.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "experiment/common.hpp"

namespace cariesim::experiment {

namespace {

constexpr double kPressDepth = 0.59;  // mm, as in the friction experiment
constexpr double kSpeed = 10.0;       // mm/s
constexpr double kWindow = 6.0;       // mm of haptic travel averaged before / after the border
constexpr double kHookProbe = 4.0;    // mm past the border at which hooking is judged
constexpr double kHookStall = 0.5;    // mm: a graphic tool this little past the border is hooked

struct Run {
  const char* name;
  double from, to;         // mm, haptic x along y = 0, relative to the border
  double healthy, caries;  // N/mm
};

}  // namespace

void run_boundary(const ExperimentOptions& options, io::JsonWriter& summary) {
  say(options, "boundary: building boundary-square");
  const Model model = build_model(load_scene("boundary-square", options.overrides), options.build);
  if (model.lesions.empty()) throw Error("boundary-square: the scene has no lesion");
  const LesionModel& lesion = model.lesions.front();
  const Vec3 c = lesion.shape.center;
  const double border = lesion_border_x(lesion.shape, c.z(), c.y());
  const double press_z = c.z() + model.tool.tip_radius - kPressDepth;

  const Run runs[] = {
      {"equal_into_frictional", -15.0, 15.0, 1.0, 1.0},
      {"equal_out_of_frictional", 15.0, -15.0, 1.0, 1.0},
      {"stiff_out_of_soft", 10.0, -10.0, 50.0, 0.1},
      {"stiff_into_soft", -10.0, 10.0, 50.0, 0.1},
  };
  summary.field("experiment", "boundary").field("paper", "Fig. 12, §4.2.1").field("border_x_mm", border);
  summary.field("press_depth_mm", kPressDepth).field("speed_mm_s", kSpeed).key("runs").begin_array();
  RunChecks checks;
  for (const Run& run : runs) {
    // Stiffness of the healthy region and of the caries for this run.
    Params params = model.defaults;
    for (Material& m : params.materials) m.stiffness = m.lesion == 0 ? run.caries : run.healthy;
    const double x0 = border + run.from, x1 = border + run.to;
    const double dir = x1 > x0 ? 1.0 : -1.0;
    // The explorer is drawn over the surface with its handle leaning back against the motion, so
    // that the tip (not the shank ahead of it) meets the border: the home posture leans toward -x,
    // turned half a revolution about the vertical for runs toward -x.
    const Quat q =
        dir > 0.0
            ? model.tool_home.q
            : (Quat(Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitZ())) * model.tool_home.q).normalized();
    Path path(at(Vec3(x0, c.y(), c.z() + 2.0), q));
    path.to(0.5, at(Vec3(x0, c.y(), press_z), q)).hold(0.3);
    path.to(std::abs(x1 - x0) / kSpeed, at(Vec3(x1, c.y(), press_z), q));
    path.to(0.5, at(Vec3(x1, c.y(), c.z() + 2.0), q));
    const std::vector<SimSample> samples = simulate(model, params, path.trajectory(), options.rate_hz);
    checks.add(model, samples);

    // Tangential force before and after the border, by the haptic tool's travel; hooking.
    double before = 0.0, after = 0.0;
    int n_before = 0, n_after = 0;
    double graphic_past = -1e9;
    bool probed = false;
    std::vector<std::vector<double>> rows;
    for (const SimSample& s : samples) {
      const double h = dir * (s.out.haptic.p.x() - border);  // haptic travel past the border, mm
      const double g = dir * (s.out.graphic.p.x() - border);
      const bool pressing = s.out.haptic.p.z() <= press_z + 1e-6;
      const double ft = std::abs(s.out.force.x());
      if (pressing && h > -kWindow - 1.0 && h < -1.0) before += ft, ++n_before;
      if (pressing && h > 1.0 && h < kWindow + 1.0) after += ft, ++n_after;
      if (pressing && !probed && h >= kHookProbe) {
        graphic_past = g;
        probed = true;
      }
      rows.push_back({s.t, s.out.haptic.p.x() - border, s.out.graphic.p.x() - border, s.out.graphic.p.z(),
                      s.out.force.x(), s.out.force.z()});
    }
    const double ft_before = n_before ? before / n_before : 0.0;
    const double ft_after = n_after ? after / n_after : 0.0;
    const bool hooked = probed && graphic_past < kHookStall;
    const std::string csv = std::string("boundary_") + run.name + ".csv";
    write_csv(options.out / csv, {"t", "h_x_from_border", "g_x_from_border", "g_z", "fx", "fz"}, rows);
    say(options, "boundary: " + std::string(run.name) + ": Ft " + std::to_string(ft_before) + " -> " +
                     std::to_string(ft_after) + " N" + (hooked ? ", hooked" : ""));
    summary.begin_object()
        .field("name", run.name)
        .field("direction", dir > 0 ? "healthy_to_caries" : "caries_to_healthy")
        .field("healthy_stiffness", run.healthy)
        .field("caries_stiffness", run.caries)
        .field("stiffness_ratio", run.healthy / run.caries)
        .field("ft_before", ft_before)
        .field("ft_after", ft_after)
        .field("graphic_past_border_mm", graphic_past)
        .field("hooked", hooked)
        .field("csv", csv)
        .end_object();
  }
  summary.end_array();
  checks.write(summary);
}

}  // namespace cariesim::experiment

namespace cariesim {

double lesion_border_x(const LesionShape& shape, double surface_z, double y0) {
  double inside = shape.center.x(), outside = shape.center.x() - 200.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (inside + outside);
    (shape.distance(Vec3(mid, y0, surface_z - 0.5 * shape.depth)) < 0.0 ? inside : outside) = mid;
  }
  return 0.5 * (inside + outside);
}

}  // namespace cariesim
