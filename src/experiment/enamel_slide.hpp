#pragma once
/// A frictionless slide over scanned enamel (the real arch's tooth 46, its buccal surface): how smooth
/// a smooth tooth feels. The hand follows the scan's surface 0.6 mm inside it along the surface normal,
/// so that the coupling (k_trans 1 N/mm) presses with 0.6 N, and moves at 5 mm/s; the tangential force
/// is the rendered force's part in the scan's tangent plane (the mesh's vertex normals interpolated at
/// the point nearest the graphic tip). `cariesim experiment friction` reports its ripple
/// (docs/cli.md) and the tests hold it under 0.02 N (docs/step.md, "Force shading").
#include <string>
#include <vector>

#include "cariesim/render/model.hpp"

namespace cariesim::experiment {

inline constexpr double kEnamelSlideLoad = 0.6;     ///< N, normal load of the slide
inline constexpr double kEnamelSlideSpeed = 5.0;    ///< mm/s
inline constexpr double kEnamelRippleWindow = 0.5;  ///< mm of slide the ripple is taken over

/// The force along the slide, one entry per servo step of the slide's measured part.
struct EnamelSlide {
  std::vector<double> s;        ///< mm, how far along the slide (world y) the graphic tip is
  std::vector<double> along;    ///< N, tangential force along the slide direction
  std::vector<double> across;   ///< N, tangential force across it (in the tangent plane)
  std::vector<double> normal;   ///< N, force along the scan's normal (the load)
  std::vector<int> free_steps;  ///< indices of steps whose state was free (the tip lost the surface)
  /// N: the largest peak-to-peak of `along` or `across` over any kEnamelRippleWindow of s.
  double ripple = 0.0;
  double mean_normal = 0.0;            ///< N
  double max_rigid_penetration = 0.0;  ///< mm, of the whole run (experiment/common.hpp's measure)
};

/// Runs the slide on `real_arch` (a model of the real-arch scene: it needs its object "tooth46" and
/// that tooth's display mesh) with `params` (make the materials frictionless for the ripple). Throws
/// cariesim::Error when the model has no tooth46.
EnamelSlide enamel_slide(const Model& real_arch, const Params& params, double rate_hz = 1000.0);

/// The largest peak-to-peak over any window of `window` mm of s of the values `v` (s ascending).
double window_ripple(const std::vector<double>& s, const std::vector<double>& v, double window);

}  // namespace cariesim::experiment
