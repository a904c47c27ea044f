#pragma once
/// Math types shared by every module. Units: millimetre, newton, N·mm, N/mm, second.
/// Frames are right-handed; a Pose maps tool (or object) coordinates into the world.

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cariesim/common/hash.hpp"

namespace cariesim {

using Vec3 = Eigen::Vector3d;                 ///< 3-vector, double
using Vec3f = Eigen::Vector3f;                ///< 3-vector, float (storage in sphere trees)
using Vec6 = Eigen::Matrix<double, 6, 1>;     ///< 6-D configuration or wrench (translation first)
using Mat3 = Eigen::Matrix3d;                 ///< 3 x 3
using Mat6 = Eigen::Matrix<double, 6, 6>;     ///< 6 x 6
using Quat = Eigen::Quaterniond;              ///< unit quaternion (w, x, y, z)

/// A rigid transform. For the tool: origin at the centre of the tip sphere, +z along the tip segment
/// pointing away from the tip (toward the handle); the insertion direction is therefore -z.
struct Pose {
  Vec3 p = Vec3::Zero();      ///< mm, position of the frame origin in the world
  Quat q = Quat::Identity();  ///< orientation of the frame in the world (unit)

  /// Maps a point given in this frame into the world (mm).
  [[nodiscard]] Vec3 transform(const Vec3& local) const { return p + q * local; }
  /// The frame's +z axis in the world (unit).
  [[nodiscard]] Vec3 z_axis() const { return q * Vec3::UnitZ(); }
  /// True when every component is finite and q has unit length within 1e-6.
  [[nodiscard]] bool finite() const {
    return p.allFinite() && q.coeffs().allFinite() && std::abs(q.squaredNorm() - 1.0) < 1e-6;
  }
};
/// A key hashes both fields of a Pose (common/hash.hpp).
template <>
inline constexpr std::size_t kKeyFields<Pose> = 2;

/// Rotation vector (axis * angle, rad) of a unit quaternion; the angle is in [0, pi].
inline Vec3 rotation_vector(const Quat& q_in) {
  Quat q = q_in.w() < 0.0 ? Quat(-q_in.w(), -q_in.x(), -q_in.y(), -q_in.z()) : q_in;
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();  // small-angle limit
  const double angle = 2.0 * std::atan2(s, q.w());
  return q.vec() * (angle / s);
}

/// An orthonormal tangent pair of a unit normal n, with (t1, t2, n) right-handed: t1 = n × h / |n × h|
/// and t2 = n × t1, where h is the world axis `axis` (0 x, 1 y, 2 z), or the next one when n lies
/// within about 25° of it.
inline void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2, int axis = 0) {
  const Vec3 helper = std::abs(n[axis]) < 0.9 ? Vec3::Unit(axis) : Vec3::Unit((axis + 1) % 3);
  t1 = n.cross(helper).normalized();
  t2 = n.cross(t1);
}

/// Unit quaternion from a rotation vector (axis * angle, rad).
inline Quat quat_from_rotation_vector(const Vec3& v) {
  const double angle = v.norm();
  if (angle < 1e-12) return Quat(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  return Quat(Eigen::AngleAxisd(angle, v / angle));
}

}  // namespace cariesim
