#pragma once
/// A frictionless slide over scanned enamel (the real arch's tooth 46, its buccal surface, or 44's): how
/// smooth a smooth tooth feels. The hand follows the scan's surface 0.6 mm inside it along the surface
/// normal, so that the coupling (k_trans 1 N/mm) presses with 0.6 N, and moves at 5 mm/s; the tangential
/// force is the rendered force's part in the scan's tangent plane (the mesh's vertex normals interpolated at
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

/// Where a slide runs: on the object whose name starts with `tooth`, along the line from `from` to
/// `to` (world mm, outside the tooth), each point of it moved along `inward` until it meets the scan.
struct SlideSpec {
  std::string tooth;
  Vec3 from = Vec3::Zero();     ///< mm, world
  Vec3 to = Vec3::Zero();       ///< mm, world
  Vec3 inward = Vec3::UnitX();  ///< unit, toward the tooth
  double reach = 30.0;          ///< mm, how far along `inward` the scan is looked for
};

/// 46's buccal surface (the slide the experiment and the ripple goal are about): at height z = 4.75
/// mm from y = -3.5 to 1.0 (mesial to distal), where the crown is smooth and convex.
SlideSpec molar_buccal_slide();
/// 44's buccal surface (a premolar: a more curved face than 46's): 3 mm along the arch across the
/// middle of its buccal face, at z = 3.5 mm (5 mm above its cemento-enamel junction).
SlideSpec premolar_buccal_slide();

/// Runs `spec`'s slide on `real_arch` (a model of the real-arch scene with that tooth and its display
/// mesh) with `params` (make the materials frictionless for the ripple). Throws cariesim::Error when
/// the model has no such tooth or the line misses its scan.
EnamelSlide enamel_slide(const Model& real_arch, const Params& params, const SlideSpec& spec,
                         double rate_hz = 1000.0);
/// The molar's slide.
EnamelSlide enamel_slide(const Model& real_arch, const Params& params, double rate_hz = 1000.0);

/// The largest peak-to-peak over any window of `window` mm of s of the values `v` (s ascending).
double window_ripple(const std::vector<double>& s, const std::vector<double>& v, double window);

}  // namespace cariesim::experiment
