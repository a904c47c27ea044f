// The dental explorer: a centre line (tip segment, curved working end, tapered shank, handle) with a
// radius profile, turned into a chain of spheres for collision and a tube mesh for display.
// Tool frame (docs/tool-frame.md): origin at the centre of the tip sphere, +z along the tip segment
// toward the handle; the working end bends from +z toward +x, so the tool lies in the x-z plane.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/procedural.hpp"

namespace cariesim {

namespace {

// Largest scallop (mm) allowed on the shank and on the handle.
constexpr double kShankGap = 0.05;
constexpr double kHandleGap = 0.5;
// Length (mm) over which the handle's radius grows from the shank's (a conical ferrule).
constexpr double kFerrule = 6.0;
// Upper bound on the chain, against a runaway max_gap.
constexpr std::size_t kMaxSpheres = 4096;
// Facets around the display tube.
constexpr int kAround = 24;

void require(bool ok, const std::string& problem) {
  if (!ok) throw Error(fmt::format("explorer: {}", problem));
}

// Centre line and radius profile, parameterised by arc length s (mm) from the tip.
class CentreLine {
 public:
  explicit CentreLine(const ExplorerParams& p) : p_(p) {
    const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
    require(positive(p.tip_radius) && positive(p.tip_segment) && positive(p.working_end_radius) &&
                positive(p.bend_radius) && positive(p.bend_angle) && positive(p.shank_length) &&
                positive(p.shank_radius) && positive(p.handle_length) && positive(p.handle_radius),
            "every dimension must be finite and positive");
    require(p.bend_angle <= std::numbers::pi, fmt::format("bend_angle {} rad exceeds pi", p.bend_angle));
    require(p.tip_radius <= p.working_end_radius && p.working_end_radius <= p.shank_radius &&
                p.shank_radius <= p.handle_radius,
            "radii must grow from the tip to the handle");
    require(p.working_end_radius < p.bend_radius, "the working end is thicker than its bend radius");
    require(p.handle_length > 2.0 * p.handle_radius + ferrule(), "the handle is too short for its radius");
    require(p.tip_segment + p.bend_radius * p.bend_angle + p.shank_length + p.handle_length < 1000.0,
            "the tool is longer than a metre");
    ends_ = {p.tip_segment, p.tip_segment + p.bend_radius * p.bend_angle, 0.0, 0.0};
    ends_[2] = ends_[1] + p.shank_length;
    ends_[3] = ends_[2] + p.handle_length;
  }

  // Arc length (mm) where segment k (0 tip segment, 1 working end, 2 shank, 3 handle) ends.
  [[nodiscard]] double end(int k) const { return ends_[static_cast<std::size_t>(k)]; }
  // Where the chain and the tube stop: the handle's rounded end is centred one radius before its end.
  [[nodiscard]] double last() const { return ends_[3] - p_.handle_radius; }
  [[nodiscard]] double ferrule() const { return std::min(kFerrule, 0.25 * p_.handle_length); }

  [[nodiscard]] int segment(double s) const {
    for (int k = 0; k < 3; ++k) {
      if (s < end(k)) return k;
    }
    return 3;
  }

  [[nodiscard]] Vec3 point(double s) const {
    if (s <= end(0)) return {0.0, 0.0, s};
    const double r = p_.bend_radius;
    if (s <= end(1)) {
      const double phi = (s - end(0)) / r;
      return {r * (1.0 - std::cos(phi)), 0.0, end(0) + r * std::sin(phi)};
    }
    const double a = p_.bend_angle;
    return Vec3(r * (1.0 - std::cos(a)), 0.0, end(0) + r * std::sin(a)) + (s - end(1)) * tangent(s);
  }

  [[nodiscard]] Vec3 tangent(double s) const {
    const double phi = std::clamp((s - end(0)) / p_.bend_radius, 0.0, p_.bend_angle);
    return {std::sin(phi), 0.0, std::cos(phi)};
  }

  // Wire radius (mm): linear from the tip to the working end's end, then along the shank, then the
  // ferrule up to the handle's radius.
  [[nodiscard]] double radius(double s) const {
    if (s <= end(1))
      return p_.tip_radius + (p_.working_end_radius - p_.tip_radius) * std::max(s, 0.0) / end(1);
    if (s <= end(2))
      return p_.working_end_radius +
             (p_.shank_radius - p_.working_end_radius) * (s - end(1)) / p_.shank_length;
    const double t = std::min((s - end(2)) / ferrule(), 1.0);
    return p_.shank_radius + (p_.handle_radius - p_.shank_radius) * t;
  }

  // How far the union of the spheres at s0 < s1 dips below the tube between them (mm): the tube's
  // radius where the spheres' intersection circle lies less that circle's radius; on the bend, the
  // outer side is also checked in the bend plane.
  [[nodiscard]] double scallop(double s0, double s1) const {
    const double r0 = radius(s0);
    const double r1 = radius(s1);
    const double d = (point(s1) - point(s0)).norm();
    if (d >= r0 + r1) return std::max(r0, r1);
    const double x = (d * d + r0 * r0 - r1 * r1) / (2.0 * d);
    const double rho = std::sqrt(std::max(r0 * r0 - x * x, 0.0));
    // x may be negative where the next sphere grows faster than it moves (the ferrule): the tube's
    // radius there is extrapolated linearly.
    const double r_at = r0 + (r1 - r0) * x / d;
    double dip = r_at - rho;
    const double phi0 = std::clamp((s0 - end(0)) / p_.bend_radius, 0.0, p_.bend_angle);
    const double phi1 = std::clamp((s1 - end(0)) / p_.bend_radius, 0.0, p_.bend_angle);
    if (phi1 > phi0) {
      // Outer side of the bend: along a ray from the bend's centre at angle phi, the tube reaches
      // bend + r(phi) and each sphere its far intersection with the ray. The union dips most where
      // the two spheres reach equally far (the one falls, the other rises with phi): bisection.
      const double bend = p_.bend_radius;
      auto reach = [&](double phi, double phi_i, double r_i) {
        const double off = bend * std::sin(phi - phi_i);
        return r_i * r_i >= off * off ? bend * std::cos(phi - phi_i) + std::sqrt(r_i * r_i - off * off) : 0.0;
      };
      double lo = phi0;
      double hi = phi1;
      for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (reach(mid, phi0, r0) > reach(mid, phi1, r1) ? lo : hi) = mid;
      }
      const double phi = 0.5 * (lo + hi);
      const double union_reach = std::max(reach(phi, phi0, r0), reach(phi, phi1, r1));
      dip = std::max(dip, bend + radius(end(0) + phi * bend) - union_reach);
    }
    return dip;
  }

  [[nodiscard]] double gap(int segment, double max_gap) const {
    return segment <= 1 ? max_gap : (segment == 2 ? kShankGap : kHandleGap);
  }

 private:
  ExplorerParams p_;
  std::array<double, 4> ends_{};
};

}  // namespace

std::vector<ToolSphere> make_explorer_spheres(const ExplorerParams& params, double max_gap) {
  const CentreLine line(params);
  require(std::isfinite(max_gap) && max_gap >= 1e-4 && max_gap <= 1.0,
          fmt::format("max_gap {} mm is outside [0.0001, 1] mm", max_gap));

  // Walk the centre line from the tip: each step is the longest whose scallop stays within the
  // segment's bound (bisection; the scallop grows with the step), stopping at segment ends.
  std::vector<ToolSphere> spheres;
  double s = 0.0;
  while (true) {
    const int seg = line.segment(s);
    spheres.push_back({line.point(s), line.radius(s), static_cast<uint16_t>(seg)});
    require(spheres.size() <= kMaxSpheres,
            fmt::format("more than {} spheres: max_gap is too small", kMaxSpheres));
    if (s >= line.last()) break;
    const double bound = line.gap(seg, max_gap);
    const double stop = std::min(seg < 3 ? line.end(seg) : line.last(), line.last());
    double lo = 0.0;
    double hi = std::min(2.0 * line.radius(s), stop - s);
    if (line.scallop(s, s + hi) > bound) {
      for (int i = 0; i < 50; ++i) {
        const double mid = 0.5 * (lo + hi);
        (line.scallop(s, s + mid) <= bound ? lo : hi) = mid;
      }
      hi = std::max(lo, 1e-6);  // always progress; kMaxSpheres stops a runaway
    }
    s = hi >= stop - s - 1e-9 ? stop : s + hi;
  }
  return spheres;
}

TriangleMesh make_explorer_mesh(const ExplorerParams& params) {
  const CentreLine line(params);
  TriangleMesh mesh;

  // Ring stations along the centre line: about half a radius apart, at most 3 degrees on the bend,
  // and at every segment end.
  std::vector<double> stations{0.0};
  {
    double s = 0.0;
    while (s < line.last()) {
      double step = std::clamp(0.5 * line.radius(s), 0.02, 2.0);
      const int seg = line.segment(s);
      if (seg == 1) step = std::min(step, params.bend_radius * (3.0 * std::numbers::pi / 180.0));
      const double stop = seg < 3 ? std::min(line.end(seg), line.last()) : line.last();
      s = std::min(s + step, stop);
      stations.push_back(s);
    }
  }

  // A ring of kAround vertices around the centre line at s; frame: +y and the in-plane normal.
  auto ring = [&](const Vec3& centre, const Vec3& tangent, double r) {
    const auto first = static_cast<uint32_t>(mesh.vertices.size());
    const Vec3 side = Vec3::UnitY();
    const Vec3 normal = side.cross(tangent);
    for (int i = 0; i < kAround; ++i) {
      const double theta = 2.0 * std::numbers::pi * i / kAround;
      mesh.vertices.push_back(
          (centre + r * (std::cos(theta) * normal + std::sin(theta) * side)).cast<float>());
    }
    return first;
  };
  // Quads between two consecutive rings (a at smaller s), wound outward.
  auto join = [&](uint32_t a, uint32_t b) {
    for (uint32_t i = 0; i < kAround; ++i) {
      const uint32_t j = (i + 1) % kAround;
      mesh.triangles.push_back({a + i, b + j, b + i});
      mesh.triangles.push_back({a + i, a + j, b + j});
    }
  };
  // A hemisphere cap over the ring `edge` (centre c, radius r), bulging along `out`; `at_start` says
  // whether the cap comes before the ring along the centre line.
  auto cap = [&](uint32_t edge, const Vec3& c, const Vec3& tangent, const Vec3& out, double r,
                 bool at_start) {
    constexpr int kLatitudes = 6;
    uint32_t previous = edge;
    for (int k = kLatitudes - 1; k >= 1; --k) {
      const double beta = 0.5 * std::numbers::pi * k / kLatitudes;  // from the pole
      const uint32_t current = ring(c + out * (r * std::cos(beta)), tangent, r * std::sin(beta));
      at_start ? join(current, previous) : join(previous, current);
      previous = current;
    }
    const auto pole = static_cast<uint32_t>(mesh.vertices.size());
    mesh.vertices.push_back((c + out * r).cast<float>());
    for (uint32_t i = 0; i < kAround; ++i) {
      const uint32_t j = (i + 1) % kAround;
      if (at_start) {
        mesh.triangles.push_back({pole, previous + j, previous + i});
      } else {
        mesh.triangles.push_back({pole, previous + i, previous + j});
      }
    }
  };

  // Tube rings, then the tip's and the handle's hemispheres.
  std::vector<uint32_t> rings;
  for (const double s : stations) rings.push_back(ring(line.point(s), line.tangent(s), line.radius(s)));
  for (std::size_t k = 0; k + 1 < rings.size(); ++k) join(rings[k], rings[k + 1]);
  cap(rings.front(), line.point(0.0), line.tangent(0.0), -line.tangent(0.0), line.radius(0.0), true);
  cap(rings.back(), line.point(line.last()), line.tangent(line.last()), line.tangent(line.last()),
      line.radius(line.last()), false);

  MeshLoadOptions options;
  options.fill_small_holes = false;
  options.check_self_intersections = false;
  validate_mesh(mesh, "explorer mesh", nullptr, options);
  return mesh;
}

}  // namespace cariesim
