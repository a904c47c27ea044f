// A frictionless slide over the real arch's scanned enamel (tooth 46's buccal surface, or 44's) at 0.6 N and
// 5 mm/s, and the tangential force it renders (docs/step.md, "Force shading"). The hand path and the
// tangent planes come from the scan itself: the display mesh's area-weighted vertex normals
// interpolated at the nearest point, the smooth surface a dentist's explorer slides on.
#include "experiment/enamel_slide.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/nearest.hpp"
#include "cariesim/geometry/ray_cast.hpp"
#include "experiment/common.hpp"

namespace cariesim::experiment {

namespace {

constexpr double kWaypoint = 0.05;  // mm between the hand path's waypoints (along the slide)
constexpr double kSettle = 0.1;     // s after the slide starts before the force is measured
constexpr double kNear = 2.0;       // mm: the triangles within this of the slide's line are searched

// The scan's surface near the slide: its triangles there and the vertex normals.
struct Surface {
  const TriangleMesh* mesh = nullptr;
  std::vector<Vec3> vertex_normal;
  std::vector<uint32_t> near;  // triangles with a vertex near the slide

  // The point of the surface nearest `x` and the interpolated normal there (unit).
  void nearest(const Vec3& x, Vec3* point, Vec3* normal) const {
    double best = std::numeric_limits<double>::infinity();
    for (const uint32_t t : near) {
      const auto& tri = mesh->triangles[t];
      const Vec3 a = mesh->vertices[tri[0]].cast<double>(), b = mesh->vertices[tri[1]].cast<double>(),
                 c = mesh->vertices[tri[2]].cast<double>();
      double u = 0.0, v = 0.0;  // barycentric weights of b and c
      const Vec3 q = closest_on_triangle(x, a, b, c, &u, &v);
      const double d = (q - x).squaredNorm();
      if (d >= best) continue;
      best = d;
      *point = q;
      *normal =
          ((1.0 - u - v) * vertex_normal[tri[0]] + u * vertex_normal[tri[1]] + v * vertex_normal[tri[2]])
              .normalized();
    }
  }
};

// The tooth's scanned surface: the uncut mesh of its healthy part (an object cut by lesions keeps it
// as `whole`), or its only part's mesh.
const TriangleMesh& tooth_mesh(const Model& m, const std::string& tooth) {
  for (const DisplayPart& part : m.display) {
    if (part.object < 0 || static_cast<std::size_t>(part.object) >= m.objects.size()) continue;
    if (m.objects[static_cast<std::size_t>(part.object)].name.rfind(tooth, 0) != 0) continue;
    if (!part.whole.triangles.empty()) return part.whole;
    if (!part.cut) return part.mesh;
  }
  throw Error("enamel slide: the model has no " + tooth + " (the real-arch scene's) with a display mesh");
}

// The triangles with a vertex within kNear of the slide's line (across it, in the plane the line and
// `inward` span, on either side of the tooth) and along it.
Surface slide_surface(const TriangleMesh& mesh, const SlideSpec& spec) {
  Surface s;
  s.mesh = &mesh;
  s.vertex_normal = vertex_normals(mesh);
  const Vec3 along = (spec.to - spec.from).normalized();
  const Vec3 up = along.cross(spec.inward).normalized();
  const double length = (spec.to - spec.from).norm();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (const uint32_t v : mesh.triangles[t]) {
      const Vec3 p = mesh.vertices[v].cast<double>() - spec.from;
      const double a = p.dot(along);
      if (std::abs(p.dot(up)) < kNear && a > -kNear && a < length + kNear) {
        s.near.push_back(static_cast<uint32_t>(t));
        break;
      }
    }
  }
  return s;
}

// The explorer's orientation for the slide: its tip segment (leaf 0 toward the leaves within 1 mm of
// it) along 46's buccal normal at the slide's middle, the tip pointing into the tooth, turned about
// that axis so that the handle rises (world +z) away from the gingiva.
Quat slide_orientation(const Model& m, const Vec3& outward) {
  const SphereTree& tool = m.tool.tree;
  const Vec3 tip = tool.nodes[tool.leaf_nodes[0]].center.cast<double>();
  Vec3 shank = Vec3::Zero(), far = tip;
  for (const uint32_t node : tool.leaf_nodes) {
    const Vec3 c = tool.nodes[node].center.cast<double>();
    if ((c - tip).norm() < 1.0) shank += c - tip;
    if ((c - tip).norm() > (far - tip).norm()) far = c;
  }
  const Quat onto = Quat::FromTwoVectors(shank.normalized(), outward.normalized());
  Quat best = onto;
  double highest = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 36; ++k) {
    const Quat q = Quat(Eigen::AngleAxisd(k * 2.0 * std::numbers::pi / 36.0, outward.normalized())) * onto;
    const double z = (q * (far - tip)).z();
    if (z > highest) highest = z, best = q;
  }
  return best.normalized();
}

}  // namespace

double window_ripple(const std::vector<double>& s, const std::vector<double>& v, double window) {
  double worst = 0.0;
  for (std::size_t i = 0; i < s.size() && i < v.size(); ++i) {
    double lo = v[i], hi = v[i];
    for (std::size_t j = i + 1; j < s.size() && j < v.size() && s[j] - s[i] <= window; ++j) {
      lo = std::min(lo, v[j]);
      hi = std::max(hi, v[j]);
    }
    worst = std::max(worst, hi - lo);
  }
  return worst;
}

SlideSpec molar_buccal_slide() {
  SlideSpec spec;
  spec.tooth = "tooth46";
  spec.from = Vec3(-40.0, -3.5, 4.75);
  spec.to = Vec3(-40.0, 1.0, 4.75);
  spec.inward = Vec3::UnitX();
  spec.reach = 30.0;
  return spec;
}

SlideSpec premolar_buccal_slide() {
  // 44 (CEJ at (-15.8, -14.7, -1.6) in the real-arch frame, its highest cusp at z = 6.8): its buccal
  // face looks out of the arch, along (-0.73, -0.68); the slide runs along the arch at z = 3.5, the
  // crown's middle third, 1.5 mm each side of the long axis, from distal (toward 45) to mesial.
  SlideSpec spec;
  spec.tooth = "tooth44";
  const Vec3 inward = Vec3(0.73, 0.68, 0.0).normalized();
  const Vec3 along = Vec3(0.68, -0.73, 0.0).normalized();
  const Vec3 middle = Vec3(-15.8, -14.7, 3.5) - 10.0 * inward;
  spec.from = middle - 1.5 * along;
  spec.to = middle + 1.5 * along;
  spec.inward = inward;
  spec.reach = 15.0;
  return spec;
}

EnamelSlide enamel_slide(const Model& m, const Params& params, double rate_hz) {
  return enamel_slide(m, params, molar_buccal_slide(), rate_hz);
}

EnamelSlide enamel_slide(const Model& m, const Params& params, const SlideSpec& spec, double rate_hz) {
  const TriangleMesh& mesh = tooth_mesh(m, spec.tooth);
  const Surface surface = slide_surface(mesh, spec);
  const double r_tip = m.tool.tip_radius;
  const double press = kEnamelSlideLoad / params.gains.k_trans;  // mm inside the surface
  const Vec3 direction = (spec.to - spec.from).normalized();
  const double length = (spec.to - spec.from).norm();

  // The surface points of the slide: where each point of the line, moved along `inward`, enters the
  // crown; the hand follows them `press` mm inside along the interpolated normal.
  std::vector<Vec3> points, normals;
  for (double a = 0.0; a <= length + 1e-9; a += kWaypoint) {
    const Vec3 start = spec.from + a * direction;
    const std::optional<double> t = nearest_crossing(mesh, start, spec.inward, spec.reach);
    if (!t)
      throw Error("enamel slide: " + spec.tooth + "'s surface not found " + std::to_string(a) +
                  " mm along the slide");
    Vec3 point, normal;
    surface.nearest(start + *t * spec.inward, &point, &normal);
    points.push_back(point);
    normals.push_back(normal);
  }
  const Quat q = slide_orientation(m, normals[normals.size() / 2]);
  const auto hand = [&](std::size_t i, double depth) {
    return at(points[i] + normals[i] * (r_tip - depth), q);
  };
  Path path(hand(0, -1.0));
  path.to(0.3, hand(0, press)).hold(0.3);
  const double slide_start = path.end();
  for (std::size_t i = 1; i < points.size(); ++i)
    path.to((points[i] - points[i - 1]).norm() / kEnamelSlideSpeed, hand(i, press));

  const std::vector<SimSample> samples = simulate(m, params, path.trajectory(), rate_hz);
  EnamelSlide out;
  out.max_rigid_penetration = max_rigid_penetration(m, samples);
  // The force in the scan's tangent plane at the graphic tip, along and across the slide (its
  // direction laid into the plane), by how far along the slide the graphic tip is.
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const SimSample& sample = samples[i];
    if (sample.t < slide_start + kSettle) continue;
    const Vec3 g = sample.out.graphic.p;
    const double s = (g - points.front()).dot(direction);  // mm along the slide
    Vec3 point, n;
    surface.nearest(g, &point, &n);
    const Vec3 f = sample.out.force;
    const Vec3 along = (direction - direction.dot(n) * n).normalized();
    const Vec3 across = n.cross(along);
    out.s.push_back(s);
    out.along.push_back(f.dot(along));
    out.across.push_back(f.dot(across));
    out.normal.push_back(f.dot(n));
    if (sample.out.state == InteractionState::Free)
      out.free_steps.push_back(static_cast<int>(out.s.size()) - 1);
  }
  out.ripple = std::max(window_ripple(out.s, out.along, kEnamelRippleWindow),
                        window_ripple(out.s, out.across, kEnamelRippleWindow));
  double sum = 0.0;
  for (const double v : out.normal) sum += v;
  out.mean_normal = out.normal.empty() ? 0.0 : sum / static_cast<double>(out.normal.size());
  return out;
}

}  // namespace cariesim::experiment
