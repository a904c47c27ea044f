#pragma once
/// The viewer's orbit camera: it looks at a target point from a distance, turned by yaw (about the
/// world's +z, the scene's up axis) and pitch. It gives the view and projection matrices for OpenGL
/// and the screen <-> world mappings the mouse device needs.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cariesim/common/math.hpp"

namespace cariesim::viewer {

using Mat4f = Eigen::Matrix4f;  ///< 4 x 4, column-major as OpenGL expects

class OrbitCamera {
 public:
  Vec3 target = Vec3::Zero();  ///< mm, the point looked at (world)
  double distance = 100.0;     ///< mm, from the eye to the target
  double yaw = 0.0;            ///< rad, about world +z; 0 looks along +y (from the front of the mouth)
  double pitch = 0.85;         ///< rad, above the horizontal plane (positive looks down)
  double fov_y = 0.6;          ///< rad, vertical field of view

  /// Frames a box: the target at its centre, the distance so that the whole box fits in view.
  void frame(const Eigen::AlignedBox3d& box);
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
