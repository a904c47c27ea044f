#include "soft_dent.hpp"

#include <algorithm>
#include <cmath>

namespace cariesim::viewer {

double dent_radius(double depth) { return 1.0 + 4.0 * std::max(depth, 0.0); }

bool dent_from_contact(const ContactReport& contact, double stiffness, Dent& out) {
  // Only compliant tissue with a finite, positive spring and a positive load dents.
  if (!(stiffness > 0.0) || !std::isfinite(stiffness) || !(contact.force > 0.0) ||
      !std::isfinite(contact.force))
    return false;
  const double n = contact.normal.norm();
  if (!(n > 1e-9) || !contact.point.allFinite()) return false;
  out.normal = contact.normal / n;
  // Penetration of the compliant contact; a dent deeper than a few millimetres is not plausible.
  out.depth = std::min(contact.force / stiffness, 5.0);
  out.surface = contact.point + out.normal * out.depth;
  return true;
}

std::size_t apply_dents(std::span<const Vec3f> base, std::span<const Dent> dents, std::span<Vec3f> out) {
  std::size_t moved = 0;
  const std::size_t n = std::min(base.size(), out.size());
  for (std::size_t i = 0; i < n; ++i) {
    // The deepest displacement any dent asks of this vertex.
    const Vec3 v = base[i].cast<double>();
    double best = 0.0;
    Vec3 best_dir = Vec3::Zero();
    for (const Dent& d : dents) {
      const double radius = dent_radius(d.depth);
      const double r2 = (v - d.surface).squaredNorm() / (radius * radius);
      if (r2 >= 1.0) continue;
      const double falloff = (1.0 - r2) * (1.0 - r2);
      const double push = d.depth * falloff;
      if (push > best) {
        best = push;
        best_dir = d.normal;
      }
    }
    out[i] = best > 0.0 ? (v - best * best_dir).cast<float>() : base[i];
    if (best > 0.0) ++moved;
  }
  return moved;
}

}  // namespace cariesim::viewer
