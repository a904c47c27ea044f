#pragma once
/// Soft tissue visibly dents where the tool presses it (docs/design.md §5): the viewer moves the display
/// vertices of gingiva and tongue near each soft-tissue contact inward by the contact's penetration,
/// with a smooth falloff around it. Computed on the render thread from the servo snapshot's contact
/// reports; the collision model is not touched.

#include <span>
#include <vector>

#include "cariesim/common/math.hpp"
#include "cariesim/render/step.hpp"

namespace cariesim::viewer {

/// One dent in a soft surface.
struct Dent {
  Vec3 surface = Vec3::Zero();  ///< mm, world: where the undeformed surface was touched
  Vec3 normal = Vec3::UnitZ();  ///< unit, world, out of the tissue
  double depth = 0.0;           ///< mm, how far the surface is pushed in at `surface`
};

/// mm: how far around its centre a dent of this depth (mm) reaches.
double dent_radius(double depth);

/// The dent of a contact report on tissue of `stiffness` (N/mm): the penetration is force/stiffness
/// (the compliant contact's spring), the undeformed surface that far out along the normal from the
/// report's point (the tool's deepest point). Returns false when it is no dent (rigid, no force).
bool dent_from_contact(const ContactReport& contact, double stiffness, Dent& out);

/// Writes `base` moved by the dents into `out` (same size): each vertex within dent_radius of a dent
/// goes inward along the dent's normal by depth·(1 - (r/R)²)², the deepest dent winning. Returns how
/// many vertices moved.
std::size_t apply_dents(std::span<const Vec3f> base, std::span<const Dent> dents, std::span<Vec3f> out);

}  // namespace cariesim::viewer
