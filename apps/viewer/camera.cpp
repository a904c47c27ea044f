#include "camera.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cariesim::viewer {

namespace {

constexpr double kFrameTightness = 0.8;  // fraction of the bounding sphere's distance

constexpr double kDeg = M_PI / 180.0;

}  // namespace

const char* preset_name(CameraPreset preset) {
  switch (preset) {
    case CameraPreset::Occlusal:
      return "occlusal";
    case CameraPreset::Buccal:
      return "buccal";
    case CameraPreset::Lingual:
      return "lingual";
    case CameraPreset::Operator:
      return "operator";
  }
  return "occlusal";
}

bool parse_preset(const std::string& name, CameraPreset& out) {
  for (const CameraPreset p :
       {CameraPreset::Occlusal, CameraPreset::Buccal, CameraPreset::Lingual, CameraPreset::Operator}) {
    if (name == preset_name(p)) {
      out = p;
      return true;
    }
  }
  return false;
}

void OrbitCamera::look(CameraPreset preset, const Vec3& focus, const Vec3& arch_center, double distance_mm,
                       const std::vector<ToolSection>& tool) {
  // The buccal direction at the focus: away from the arch's centre, in the occlusal plane (+y, toward
  // the throat, when the focus sits on the centre).
  Vec3 buccal(focus.x() - arch_center.x(), focus.y() - arch_center.y(), 0.0);
  if (buccal.norm() < 1e-6) buccal = Vec3::UnitY();
  buccal.normalize();
  // forward() = (sin yaw cos pitch, cos yaw cos pitch, -sin pitch): yaw of a horizontal direction d.
  const auto yaw_of = [](const Vec3& d) { return std::atan2(d.x(), d.y()); };
  target = focus;
  distance = std::clamp(distance_mm, 1.0, 2000.0);
  switch (preset) {
    case CameraPreset::Occlusal: {
      // From above, the front of the mouth (-y) at the top of the screen; when the explorer's handle
      // stands in that line of sight, the least tilt from the vertical (5° steps, azimuths every 15°,
      // the one nearest the front-at-top first) whose line of sight clears it.
      yaw = 0.0;
      pitch = 85.0 * kDeg;
      if (tool.empty() || tool_clearance(tool) >= kOcclusalClearance) break;
      double best_yaw = yaw, best_pitch = pitch, best_clearance = tool_clearance(tool);
      for (int tilt = 1; tilt <= 12; ++tilt) {
        bool found = false;
        for (int k = 0; k < 24 && !found; ++k) {
          // Azimuths 0, +15°, -15°, +30°, ... from the front-at-top direction.
          const int step = (k + 1) / 2 * (k % 2 == 1 ? 1 : -1);
          yaw = std::remainder(step * 15.0 * kDeg, 2.0 * M_PI);
          pitch = (90.0 - 5.0 * tilt) * kDeg;
          const double c = tool_clearance(tool);
          if (c > best_clearance) {
            best_clearance = c;
            best_yaw = yaw;
            best_pitch = pitch;
          }
          found = c >= kOcclusalClearance;
        }
        if (found) break;
      }
      yaw = best_yaw;
      pitch = best_pitch;
      break;
    }
    case CameraPreset::Buccal:
      // From the cheek, looking toward the tongue, a little from above.
      yaw = yaw_of(-buccal);
      pitch = 20.0 * kDeg;
      break;
    case CameraPreset::Lingual:
      // From the tongue's side, looking out toward the cheek, more from above (over the tongue).
      yaw = yaw_of(buccal);
      pitch = 40.0 * kDeg;
      break;
    case CameraPreset::Operator:
      // From in front of the patient, over the cheek side of the working site and above, looking back
      // and in (a right-handed operator at 8 o'clock for the right side, 4 o'clock for the left): the
      // explorer's handle, which rises toward the front of the mouth, does not stand in the way.
      yaw = yaw_of((Vec3::UnitY() - buccal).normalized());
      pitch = 50.0 * kDeg;
      break;
  }
}

double OrbitCamera::tool_clearance(const std::vector<ToolSection>& tool) const {
  // Seen from the target: the angle between the eye and each section beyond the working end, less
  // the angle the section's radius spans at its distance.
  const Vec3 to_eye = -forward();
  double clearance = std::numeric_limits<double>::infinity();
  for (const ToolSection& s : tool) {
    const Vec3 d = s.center - target;
    const double r = d.norm();
    if (!(r > kWorkingEndReach)) continue;
    const double angle = std::acos(std::clamp(to_eye.dot(d) / r, -1.0, 1.0));
    clearance = std::min(clearance, angle - std::asin(std::min(1.0, s.radius / r)));
  }
  return clearance;
}

void OrbitCamera::frame(const Eigen::AlignedBox3d& box) {
  if (box.isEmpty()) return;
  // Centre on the box; back off until most of its bounding sphere fits the vertical field of view
  // (the sphere is loose around flat scenes: the whole sphere would leave them small).
  target = box.center();
  const double radius = std::max(0.5 * box.diagonal().norm(), 1.0);
  distance = std::clamp(kFrameTightness * radius / std::sin(0.5 * fov_y), 1.0, 2000.0);
}

Vec3 OrbitCamera::forward() const {
  return Vec3(std::sin(yaw) * std::cos(pitch), std::cos(yaw) * std::cos(pitch), -std::sin(pitch));
}

Vec3 OrbitCamera::right() const { return Vec3(std::cos(yaw), -std::sin(yaw), 0.0); }

Vec3 OrbitCamera::up() const { return right().cross(forward()); }

Vec3 OrbitCamera::eye() const { return target - distance * forward(); }

Mat4f OrbitCamera::view() const {
  // Rows: the screen axes in the world (right, up, backward), then the eye moved to the origin.
  const Vec3 r = right(), u = up(), b = -forward(), e = eye();
  Mat4f m = Mat4f::Identity();
  m.block<1, 3>(0, 0) = r.cast<float>().transpose();
  m.block<1, 3>(1, 0) = u.cast<float>().transpose();
  m.block<1, 3>(2, 0) = b.cast<float>().transpose();
  m(0, 3) = static_cast<float>(-r.dot(e));
  m(1, 3) = static_cast<float>(-u.dot(e));
  m(2, 3) = static_cast<float>(-b.dot(e));
  return m;
}

double OrbitCamera::near_plane() const { return std::max(0.5, 0.02 * distance); }

double OrbitCamera::far_plane() const { return distance + 600.0; }

Mat4f OrbitCamera::projection(double aspect) const {
  // The usual OpenGL perspective (clip z in [-w, w]).
  const double f = 1.0 / std::tan(0.5 * fov_y);
  const double n = near_plane(), fa = far_plane();
  Mat4f m = Mat4f::Zero();
  m(0, 0) = static_cast<float>(f / std::max(aspect, 1e-6));
  m(1, 1) = static_cast<float>(f);
  m(2, 2) = static_cast<float>((fa + n) / (n - fa));
  m(2, 3) = static_cast<float>(2.0 * fa * n / (n - fa));
  m(3, 2) = -1.0f;
  return m;
}

void OrbitCamera::orbit(double d_yaw, double d_pitch) {
  constexpr double kMaxPitch = 89.0 * M_PI / 180.0;
  yaw = std::remainder(yaw + d_yaw, 2.0 * M_PI);
  pitch = std::clamp(pitch + d_pitch, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::zoom(double factor) {
  if (!(factor > 0.0) || !std::isfinite(factor)) return;
  distance = std::clamp(distance * factor, 1.0, 2000.0);
}

double OrbitCamera::mm_per_pixel(double depth, double height_px) const {
  return 2.0 * std::max(depth, near_plane()) * std::tan(0.5 * fov_y) / std::max(height_px, 1.0);
}

bool OrbitCamera::project(const Vec3& world, double width, double height, Eigen::Vector2d& pixel) const {
  // Eye coordinates, then the perspective divide and the viewport (y down).
  const Vec3 d = world - eye();
  const double depth = d.dot(forward());
  if (!(depth > 1e-9)) return false;
  const double f = 1.0 / std::tan(0.5 * fov_y);
  const double aspect = width / std::max(height, 1.0);
  const double ndc_x = f / aspect * d.dot(right()) / depth;
  const double ndc_y = f * d.dot(up()) / depth;
  pixel = Eigen::Vector2d(0.5 * (ndc_x + 1.0) * width, 0.5 * (1.0 - ndc_y) * height);
  return true;
}

}  // namespace cariesim::viewer
