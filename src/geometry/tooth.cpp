// Procedural lower molar and premolar as implicit solids (negative inside), meshed with OpenVDB.
//
// A tooth is the smooth intersection of two parts:
//  - the lateral body: at each height z, a rounded rectangle whose half extents follow the crown's
//    profile (narrow at the cemento-enamel junction, bulging at the height of contour, narrowing toward
//    the occlusal table); below the root trunk it blends into the roots (stadium cross-sections that
//    taper to rounded apices), which are joined with a smooth union;
//  - the occlusal surface: z below a height field H(x, y) made of rounded cusp cones and marginal-ridge
//    wedges combined with a smooth maximum. Where two cusp cones meet, the difference between the two
//    highest cones measures the distance to their valley; a narrow groove (the fissure) is cut there,
//    except where a marginal ridge stands higher, which leaves mesial and distal pits.
// Values are distances in mm on the flanks and within a factor of about three in the fissures, which is
// what the mesher needs (it interpolates the zero crossing between samples).

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "geometry/implicit_mesher.hpp"
#include "geometry/sdf.hpp"

namespace cariesim {

namespace {

using sdf::rounded_rect;
using sdf::smax;
using sdf::smin;
using sdf::smoothstep;
using sdf::sq;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Half extent (mm) of the crown at height z: from `cej` at z = 0 it bulges (sine) to `max` at z_max,
// the height of contour, then narrows (parabola) to `top` at the crown height; below the CEJ the neck
// tapers by `neck_taper` mm per mm.
struct Profile {
  double cej = 0.0;         // mm
  double max = 0.0;         // mm
  double top = 0.0;         // mm
  double z_max = 0.0;       // mm
  double height = 0.0;      // mm
  double neck_taper = 0.0;  // mm/mm

  [[nodiscard]] double at(double z) const {
    // Below the neck: straight taper. Neck to height of contour: cubic Hermite from the taper's slope
    // to a flat maximum, so the cervical line shows no crease. Above: parabola to the occlusal table.
    constexpr double kNeck = -1.0;  // mm, where the straight taper ends
    if (z <= kNeck) return std::max(cej + neck_taper * z, 0.2 * cej);
    if (z < z_max) {
      const double span = z_max - kNeck;
      const double t = (z - kNeck) / span;
      const double v0 = cej + neck_taper * kNeck;
      const double h00 = 2 * t * t * t - 3 * t * t + 1;
      const double h10 = t * t * t - 2 * t * t + t;
      const double h01 = -2 * t * t * t + 3 * t * t;
      return h00 * v0 + h10 * span * neck_taper + h01 * max;
    }
    const double u = (z - z_max) / (height - z_max);
    return std::max(max - (max - top) * u * u, 0.3 * max);
  }
};

struct Cusp {
  double x, y;   // mm, tip position over the occlusal plane
  double tip;    // mm, tip height
  double round;  // mm, rounding of the tip (hyperbolic cone)
};

// A marginal ridge: a wedge along a segment whose crest runs from h0 to h1 and sags in the middle.
struct Ridge {
  double x0, y0, x1, y1;  // mm
  double h0, h1, sag;     // mm
};

// A root: stadium cross-section (radius a along x, half width b along y) tapering from z_top to the
// apex, its centre line bending from x_top to x_apex; z_tip is the apex's lowest point.
struct Root {
  double x_top, x_apex;  // mm
  double a_top, a_apex;  // mm
  double b_top, b_apex;  // mm
  double z_top, z_tip;   // mm
};

struct ToothShape {
  Profile md;                  // x half extent
  Profile buccal;              // +y extent
  Profile lingual;             // -y extent
  double corner = 0.6;         // corner radius as a fraction of the smaller half extent
  double distal_taper = 0.0;   // fraction by which the bucco-lingual width shrinks at the distal end
  double lingual_taper = 0.0;  // fraction by which the mesio-distal length shrinks at the lingual side
  std::vector<Cusp> cusps;
  double cusp_slope = 0.75;  // mm/mm
  double top_blend = 0.5;    // mm, smooth maximum between cusps and ridges
  std::vector<Ridge> ridges;
  double ridge_slope = 1.0;          // mm/mm
  double fissure_half_width = 0.22;  // mm
  double fissure_depth = 0.7;        // mm
  double rim_round = 0.7;            // mm, rounding where the flanks meet the occlusal surface
  std::vector<Root> roots;
  double root_split = -3.0;  // mm, height of the crown-to-roots transition (furcation)
  double root_blend = 1.0;   // mm, half height of that transition
  double root_union = 0.5;   // mm, smooth union between roots
  bool mirrored = false;
  double occlusal_min = -kInf;  // mm, lower bound of H over the crown (find_occlusal_min)

  // Occlusal height field H(x, y) (mm).
  [[nodiscard]] double occlusal(double x, double y) const {
    double first = -kInf;
    double second = -kInf;
    double top = -kInf;
    for (const auto& c : cusps) {
      const double d2 = (x - c.x) * (x - c.x) + (y - c.y) * (y - c.y);
      const double v = c.tip - cusp_slope * (std::sqrt(d2 + c.round * c.round) - c.round);
      if (v > first) {
        second = first;
        first = v;
      } else if (v > second) {
        second = v;
      }
      top = top == -kInf ? v : smax(top, v, top_blend);
    }
    // Marginal ridges; the fissures stop short of them (pits), on their inner side only.
    double fade = 1.0;
    for (const auto& r : ridges) {
      const double ex = r.x1 - r.x0;
      const double ey = r.y1 - r.y0;
      const double len2 = ex * ex + ey * ey;
      const double t_line = ((x - r.x0) * ex + (y - r.y0) * ey) / len2;
      const double t = std::clamp(t_line, 0.0, 1.0);
      const double dist = std::sqrt(sq(x - (r.x0 + t * ex)) + sq(y - (r.y0 + t * ey)));
      const double crest = r.h0 + (r.h1 - r.h0) * t - 4.0 * r.sag * t * (1.0 - t);
      top = smax(top, crest - ridge_slope * dist, top_blend);
      // Signed distance from the ridge's line, positive away from the crown centre.
      double outward = ((x - r.x0) * ey - (y - r.y0) * ex) / std::sqrt(len2);
      if ((-r.x0 * ey + r.y0 * ex) > 0.0) outward = -outward;
      const double window = smoothstep(-0.3, 0.0, t_line) * smoothstep(1.3, 1.0, t_line);
      fade *= 1.0 - smoothstep(-1.1, -0.5, outward) * window;
    }
    // The fissure: a groove along the valley between the two highest cusp cones.
    if (second == -kInf) return top;
    const double gap = (first - second) / (2.0 * cusp_slope);
    if (gap >= fissure_half_width) return top;
    const double u = gap / fissure_half_width;
    return top - fissure_depth * (1.0 - u * u) * (1.0 - u * u) * fade;
  }

  // Rounded-rectangle cross-section of crown and root trunk at height z (mm, signed).
  [[nodiscard]] double trunk(double x, double y, double z) const {
    const double hx = md.at(z);
    const double b = buccal.at(z);
    const double l = lingual.at(z);
    const double hy = 0.5 * (b + l);
    // The outline narrows toward distal (y) and toward lingual (x).
    const double yc = (y - 0.5 * (b - l)) / (1.0 - distal_taper * std::clamp(-x / hx, 0.0, 1.0));
    const double xc = x / (1.0 - lingual_taper * std::clamp(-yc / hy, 0.0, 1.0));
    return rounded_rect(xc, yc, hx, hy, corner * std::min(hx, hy));
  }

  [[nodiscard]] static double root(const Root& r, double x, double y, double z) {
    const double z_end = r.z_tip + r.a_apex;  // centre of the rounded apex
    const double t = std::clamp((r.z_top - z) / (r.z_top - z_end), 0.0, 1.0);
    const double xc = r.x_top + (r.x_apex - r.x_top) * t * t;
    const double a = r.a_top + (r.a_apex - r.a_top) * t;
    const double b = r.b_top + (r.b_apex - r.b_top) * t;
    const double dx = x - xc;
    const double dy = std::max(std::abs(y) - std::max(b - a, 0.0), 0.0);
    const double dz = std::max(z_end - z, 0.0);
    return std::sqrt(dx * dx + dy * dy + dz * dz) - a;
  }

  // The solid (mm, negative inside).
  [[nodiscard]] double operator()(const Vec3& p) const {
    const double x = p.x();
    const double y = mirrored ? -p.y() : p.y();
    const double z = p.z();
    double lateral = trunk(x, y, z);
    if (!roots.empty() && z < root_split + root_blend) {
      double r = kInf;
      for (const auto& root_i : roots) {
        const double v = root(root_i, x, y, z);
        r = r == kInf ? v : smin(r, v, root_union);
      }
      const double w = smoothstep(root_split + root_blend, root_split - root_blend, z);
      lateral = (1.0 - w) * lateral + w * r;
    }
    // Well below the lowest point of the occlusal surface the smooth maximum is the lateral value.
    const double scale = 1.0 / std::sqrt(1.0 + cusp_slope * cusp_slope);
    if ((z - occlusal_min) * scale <= lateral - rim_round) return lateral;
    return smax(lateral, (z - occlusal(x, y)) * scale, rim_round);
  }

  // Sets occlusal_min: the lowest H over the crown's footprint (sampled every 0.1 mm, less a margin
  // for what the sampling may miss at the bottom of a fissure).
  void find_occlusal_min() {
    const double hx = std::max(md.max, md.cej) + 1.0;
    const double hy = std::max({buccal.max, lingual.max, buccal.cej, lingual.cej}) + 1.0;
    occlusal_min = kInf;
    for (double x = -hx; x <= hx; x += 0.1) {
      for (double y = -hy; y <= hy; y += 0.1) occlusal_min = std::min(occlusal_min, occlusal(x, y));
    }
    occlusal_min -= 0.2;
  }

  // Box (mm) that holds the solid with a margin.
  [[nodiscard]] Eigen::AlignedBox3d box(double crown_height, double root_length, double margin) const {
    double hx = std::max(md.max, md.cej);
    double hy = std::max({buccal.max, lingual.max, buccal.cej, lingual.cej});
    for (const auto& r : roots) {
      hx = std::max({hx, std::abs(r.x_top) + r.a_top, std::abs(r.x_apex) + r.a_apex});
      hy = std::max({hy, r.b_top, r.b_apex});
    }
    return {Vec3(-hx - margin, -hy - margin, -root_length - margin),
            Vec3(hx + margin, hy + margin, crown_height + margin)};
  }
};

void require(bool ok, const char* who, const std::string& problem) {
  if (!ok) throw Error(fmt::format("{}: {}", who, problem));
}

void require_range(const char* who, const char* name, double value, double lo, double hi) {
  require(std::isfinite(value) && value >= lo && value <= hi, who,
          fmt::format("{} = {} mm is outside [{}, {}] mm", name, value, lo, hi));
}

// The molar's shape, laid out for 11 x 10 x 7.5 mm with 13 mm roots and scaled to the parameters.
ToothShape molar_shape(const MolarParams& p) {
  const char* who = "make_molar";
  require_range(who, "mesiodistal", p.mesiodistal, 5.0, 20.0);
  require_range(who, "buccolingual", p.buccolingual, 5.0, 20.0);
  require_range(who, "crown_height", p.crown_height, 3.0, 15.0);
  require_range(who, "root_length", p.root_length, 4.0, 30.0);
  require_range(who, "resolution", p.resolution, 0.05, 1.0);
  require(p.cusps == 4 || p.cusps == 5, who, fmt::format("cusps must be 4 or 5 (got {})", p.cusps));
  require(p.roots == 1 || p.roots == 2, who, fmt::format("roots must be 1 or 2 (got {})", p.roots));

  const double sx = p.mesiodistal / 11.0;
  const double sy = p.buccolingual / 10.0;
  const double sz = p.crown_height / 7.5;
  const double sr = p.root_length / 13.0;
  const double h = p.crown_height;
  ToothShape s;
  s.mirrored = p.mirrored;
  // Proximal contacts high (occlusal third), buccal height of contour cervical, lingual middle third.
  s.md = {4.5 * sx, 5.5 * sx, 5.0 * sx, 5.0 * sz, h, 0.12};
  s.buccal = {4.4 * sy, 5.0 * sy, 4.1 * sy, 2.0 * sz, h, 0.12};
  s.lingual = {4.3 * sy, 5.0 * sy, 4.5 * sy, 3.6 * sz, h, 0.12};
  s.corner = 0.75;
  s.distal_taper = 0.08;
  s.lingual_taper = 0.06;

  // Cusps (x mesial, y buccal): lingual cusps higher and sharper, buccal ones blunter.
  auto cusp = [&](double x, double y, double tip, double round) {
    s.cusps.push_back({x * sx, y * sy, tip * sz, round});
  };
  auto ridge = [&](double x0, double y0, double x1, double y1, double h0, double h1) {
    s.ridges.push_back({x0 * sx, y0 * sy, x1 * sx, y1 * sy, h0 * sz, h1 * sz, 0.4 * sz});
  };
  if (p.cusps == 5) {
    cusp(2.6, 2.5, 7.1, 1.3);                // mesiobuccal
    cusp(-0.7, 2.8, 6.9, 1.3);               // distobuccal
    cusp(-3.5, 1.5, 6.5, 1.0);               // distal
    cusp(2.5, -2.6, 7.5, 1.0);               // mesiolingual
    cusp(-1.8, -2.6, 7.3, 1.0);              // distolingual
    ridge(4.1, 2.3, 4.1, -2.4, 6.4, 6.5);    // mesial marginal ridge
    ridge(-3.8, 0.7, -3.3, -2.2, 6.0, 6.2);  // distal marginal ridge
  } else {
    cusp(2.4, 2.5, 7.1, 1.3);    // mesiobuccal
    cusp(-2.4, 2.5, 6.9, 1.3);   // distobuccal
    cusp(2.4, -2.6, 7.5, 1.0);   // mesiolingual
    cusp(-2.4, -2.6, 7.3, 1.0);  // distolingual
    ridge(4.1, 2.3, 4.1, -2.4, 6.4, 6.5);
    ridge(-4.1, 2.3, -4.1, -2.4, 6.0, 6.2);
  }
  s.cusp_slope = 0.75;
  s.fissure_depth = 0.7 * sz;

  // Root trunk down to the furcation, then mesial and distal roots bending distally (or one root).
  s.root_split = -3.0 * sr;
  s.root_blend = 1.0;
  const double z_top = s.root_split + s.root_blend;
  if (p.roots == 2) {
    s.roots.push_back({2.35 * sx, 1.5 * sx, 1.8 * sx, 0.7, 4.0 * sy, 1.4 * sy, z_top, -p.root_length});
    s.roots.push_back({-2.35 * sx, -2.7 * sx, 1.75 * sx, 0.7, 3.7 * sy, 1.2 * sy, z_top, -12.0 * sr});
  } else {
    s.roots.push_back({0.0, -0.5 * sx, 3.6 * sx, 1.0, 4.0 * sy, 1.6 * sy, z_top, -p.root_length});
  }
  s.find_occlusal_min();
  return s;
}

// The premolar's shape, laid out for 7 x 8 x 8 mm with a 14 mm root.
ToothShape premolar_shape(const PremolarParams& p) {
  const char* who = "make_premolar";
  require_range(who, "mesiodistal", p.mesiodistal, 4.0, 15.0);
  require_range(who, "buccolingual", p.buccolingual, 4.0, 15.0);
  require_range(who, "crown_height", p.crown_height, 3.0, 15.0);
  require_range(who, "root_length", p.root_length, 4.0, 30.0);
  require_range(who, "resolution", p.resolution, 0.05, 1.0);

  const double sx = p.mesiodistal / 7.0;
  const double sy = p.buccolingual / 8.0;
  const double sz = p.crown_height / 8.0;
  const double sr = p.root_length / 14.0;
  const double h = p.crown_height;
  ToothShape s;
  s.mirrored = p.mirrored;
  s.md = {2.5 * sx, 3.5 * sx, 3.1 * sx, 5.6 * sz, h, 0.1};
  s.buccal = {3.3 * sy, 4.0 * sy, 2.4 * sy, 2.0 * sz, h, 0.1};
  s.lingual = {3.2 * sy, 4.0 * sy, 3.0 * sy, 4.0 * sz, h, 0.1};
  s.corner = 0.8;
  s.cusps = {{0.0, 1.2 * sy, 8.0 * sz, 1.2}, {0.0, -2.2 * sy, 6.6 * sz, 0.8}};  // buccal, lingual
  s.cusp_slope = 1.0;
  s.ridges = {{2.2 * sx, 0.6 * sy, 2.0 * sx, -1.9 * sy, 6.2 * sz, 5.4 * sz, 0.2 * sz},
              {-2.2 * sx, 0.6 * sy, -2.0 * sx, -1.9 * sy, 6.2 * sz, 5.4 * sz, 0.2 * sz}};
  s.ridge_slope = 0.6;
  s.fissure_depth = 0.6 * sz;
  s.root_split = -1.5 * sr;
  s.root_blend = 1.0;
  s.roots.push_back(
      {0.0, -0.4 * sx, 2.3 * sx, 0.7, 3.2 * sy, 0.9 * sy, s.root_split + s.root_blend, -p.root_length});
  s.find_occlusal_min();
  return s;
}

// Surface height (mm) of the solid over (x, y): bisection from above the crown down to z_low.
double surface_height(const ToothShape& s, double x, double y, double z_high, double z_low) {
  if (s(Vec3(x, y, z_low)) > 0.0) return z_low;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (z_high + z_low);
    (s(Vec3(x, y, mid)) > 0.0 ? z_high : z_low) = mid;
  }
  return 0.5 * (z_high + z_low);
}

// Outermost crown point (mm) along +x (sign = 1) or -x (sign = -1), scanning heights over the crown.
Vec3 proximal_contact(const ToothShape& s, double crown_height, double sign) {
  Vec3 best = Vec3::Zero();
  const double reach = 2.0 * std::max(s.md.max, s.md.cej) + 2.0;
  for (double z = 0.0; z <= crown_height; z += 0.05) {
    const double y = 0.5 * (s.buccal.at(z) - s.lingual.at(z)) * (s.mirrored ? -1.0 : 1.0);
    double inside = 0.0;
    double outside = reach;
    if (s(Vec3(0.0, y, z)) > 0.0) continue;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (inside + outside);
      (s(Vec3(sign * mid, y, z)) > 0.0 ? outside : inside) = mid;
    }
    if (inside > std::abs(best.x())) best = Vec3(sign * inside, y, z);
  }
  return best;
}

ToothLandmarks landmarks(const ToothShape& s, double crown_height) {
  ToothLandmarks out;
  const double y_sign = s.mirrored ? -1.0 : 1.0;
  const double z_high = crown_height + 2.0;
  // Cusp tips: highest surface point near each cusp's nominal position.
  for (const auto& c : s.cusps) {
    Vec3 best(c.x, c.y, -kInf);
    for (double dx = -0.5; dx <= 0.5; dx += 0.05) {
      for (double dy = -0.5; dy <= 0.5; dy += 0.05) {
        const double z = s.occlusal(c.x + dx, c.y + dy);
        if (z > best.z()) best = Vec3(c.x + dx, c.y + dy, z);
      }
    }
    const double z = surface_height(s, best.x(), y_sign * best.y(), z_high, 0.0);
    out.cusp_tips.emplace_back(best.x(), y_sign * best.y(), z);
  }
  // Central fossa: lowest point of the occlusal surface within 1.5 mm of the cusps' centroid.
  double cx = 0.0;
  double cy = 0.0;
  for (const auto& c : s.cusps) {
    cx += c.x / static_cast<double>(s.cusps.size());
    cy += c.y / static_cast<double>(s.cusps.size());
  }
  Vec3 fossa(cx, cy, kInf);
  for (double dx = -1.5; dx <= 1.5; dx += 0.05) {
    for (double dy = -1.5; dy <= 1.5; dy += 0.05) {
      if (dx * dx + dy * dy > 1.5 * 1.5) continue;
      const double z = s.occlusal(cx + dx, cy + dy);
      if (z < fossa.z()) fossa = Vec3(cx + dx, cy + dy, z);
    }
  }
  out.central_fossa =
      Vec3(fossa.x(), y_sign * fossa.y(), surface_height(s, fossa.x(), y_sign * fossa.y(), z_high, 0.0));
  out.mesial_contact = proximal_contact(s, crown_height, 1.0);
  out.distal_contact = proximal_contact(s, crown_height, -1.0);
  return out;
}

}  // namespace

TriangleMesh make_molar(const MolarParams& params) {
  const ToothShape shape = molar_shape(params);
  const auto box = shape.box(params.crown_height, params.root_length, 3.0 * params.resolution + 0.5);
  return mesh_implicit(shape, box, params.resolution, 4.0, "make_molar");
}

TriangleMesh make_premolar(const PremolarParams& params) {
  const ToothShape shape = premolar_shape(params);
  const auto box = shape.box(params.crown_height, params.root_length, 3.0 * params.resolution + 0.5);
  return mesh_implicit(shape, box, params.resolution, 4.0, "make_premolar");
}

ToothLandmarks molar_landmarks(const MolarParams& params) {
  return landmarks(molar_shape(params), params.crown_height);
}

ToothLandmarks premolar_landmarks(const PremolarParams& params) {
  return landmarks(premolar_shape(params), params.crown_height);
}

}  // namespace cariesim
