#pragma once
/// The viewer's orbit camera: it looks at a target point from a distance, turned by yaw (about the
/// world's +z, the scene's up axis) and pitch. It gives the view and projection matrices for OpenGL
/// and the screen <-> world mappings the mouse device needs.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "cariesim/common/math.hpp"

namespace cariesim::viewer {

using Mat4f = Eigen::Matrix4f;  ///< 4 x 4, column-major as OpenGL expects

/// The clinician's views of a working site (the scenes' convention: world +z is occlusal, up; the
/// patient faces -y; buccal is away from the arch's centre): from above the occlusal surface, from
/// the cheek, from the tongue, and from where a right-handed operator sits in front of the patient
/// and looks into the lower arch from above the lip.
enum class CameraPreset : uint8_t { Occlusal, Buccal, Lingual, Operator };
/// "occlusal", "buccal", "lingual", "operator".
const char* preset_name(CameraPreset preset);
/// Parses a preset name; false when unknown.
bool parse_preset(const std::string& name, CameraPreset& out);

/// A section of the tool: a point of its centre line and the tool's radius there (mm, world).
struct ToolSection {
  Vec3 center = Vec3::Zero();  ///< mm, world
  double radius = 0.0;         ///< mm
};

/// rad, the least clearance the occlusal preset keeps between its line of sight to the tip and the
/// tool's handle (OrbitCamera::tool_clearance).
inline constexpr double kOcclusalClearance = 12.0 * M_PI / 180.0;
/// mm from the tip within which the tool (its working end) may stand in front of the tip.
inline constexpr double kWorkingEndReach = 6.0;

class OrbitCamera {
 public:
  Vec3 target = Vec3::Zero();  ///< mm, the point looked at (world)
  double distance = 100.0;     ///< mm, from the eye to the target
  double yaw = 0.0;            ///< rad, about world +z; 0 looks along +y (from the front of the mouth)
  double pitch = 0.85;         ///< rad, above the horizontal plane (positive looks down)
  double fov_y = 0.6;          ///< rad, vertical field of view

  /// Frames a box: the target at its centre, the distance so that the whole box fits in view.
  void frame(const Eigen::AlignedBox3d& box);
  /// Looks at `focus` (mm, world; e.g. the explorer's tip) from a clinical direction, `distance` mm
  /// away; `arch_center` (mm, world) tells buccal from lingual. With the tool's sections (world, tip
  /// first) the occlusal view looks past the handle: when the handle stands within
  /// kOcclusalClearance of the line of sight from above, the camera tilts (least first, up to 60°
  /// from the vertical) to the nearest direction that clears it.
  void look(CameraPreset preset, const Vec3& focus, const Vec3& arch_center, double distance_mm = 45.0,
            const std::vector<ToolSection>& tool = {});
  /// rad, how far the tool stays from the line of sight to the target: the least angle, seen from the
  /// target, between the eye and a tool section further than kWorkingEndReach from the target, less
  /// the section's angular radius (negative: the tool hides the target). Infinity without sections.
  [[nodiscard]] double tool_clearance(const std::vector<ToolSection>& tool) const;
  /// The eye position (mm, world).
  [[nodiscard]] Vec3 eye() const;
  /// Unit vectors of the view in the world: forward (into the screen), right and up on the screen.
  [[nodiscard]] Vec3 forward() const;
  [[nodiscard]] Vec3 right() const;  ///< unit, world
  [[nodiscard]] Vec3 up() const;     ///< unit, world
  /// World -> eye transform.
  [[nodiscard]] Mat4f view() const;
  /// Eye -> clip transform for a viewport of this aspect ratio (width / height).
  [[nodiscard]] Mat4f projection(double aspect) const;
  /// Near and far clip planes (mm) that hold the scene around the target.
  [[nodiscard]] double near_plane() const;
  [[nodiscard]] double far_plane() const;  ///< mm
  /// Turns the view: yaw and pitch by these angles (rad); pitch stays within ±89°.
  void orbit(double d_yaw, double d_pitch);
  /// Moves closer (factor < 1) or further (factor > 1), within [1 mm, 2 m].
  void zoom(double factor);
  /// Millimetres per pixel at a point `depth` mm in front of the eye, for a viewport `height_px` tall.
  [[nodiscard]] double mm_per_pixel(double depth, double height_px) const;
  /// Projects a world point to pixel coordinates (x right, y down, origin at the top-left corner of a
  /// width x height viewport). Returns false when the point is behind the eye.
  bool project(const Vec3& world, double width, double height, Eigen::Vector2d& pixel) const;
};

}  // namespace cariesim::viewer
