#pragma once
/// Narrow-band signed distance fields (negative inside) and CSG, backed by OpenVDB (offline only:
/// never used in the servo step). OpenVDB stays behind this interface.

#include <memory>

#include "cariesim/geometry/mesh.hpp"

namespace cariesim {

class LevelSet {
 public:
  LevelSet();
  ~LevelSet();
  LevelSet(const LevelSet&);
  LevelSet& operator=(const LevelSet&);
  LevelSet(LevelSet&&) noexcept;
  LevelSet& operator=(LevelSet&&) noexcept;

  /// Mesh -> narrow-band level set with `voxel_mm` voxels and a band of `half_band_mm` each side.
  static LevelSet from_mesh(const TriangleMesh& mesh, double voxel_mm, double half_band_mm);

  /// CSG (paper §2.2): healthy = tooth.difference(lesion), caries = tooth.intersection(lesion).
  [[nodiscard]] LevelSet united(const LevelSet& other) const;
  [[nodiscard]] LevelSet intersection(const LevelSet& other) const;
  [[nodiscard]] LevelSet difference(const LevelSet& other) const;

  /// Signed distance (mm) at a world point, trilinear; outside the band it is +/- the band width.
  [[nodiscard]] double distance(const Vec3& p) const;
  /// Gradient of the distance (unit length where defined).
  [[nodiscard]] Vec3 gradient(const Vec3& p) const;
  /// Bounds of the active voxels (mm).
  [[nodiscard]] Eigen::AlignedBox3d bounds() const;
  [[nodiscard]] double voxel_size() const;
  [[nodiscard]] double half_band() const;
  [[nodiscard]] bool empty() const;
  /// Zero iso-surface as a closed triangle mesh (display meshes).
  [[nodiscard]] TriangleMesh to_mesh(double adaptivity = 0.0) const;

  /// The OpenVDB grid behind this level set (defined in src/spheretree only).
  struct Impl;
  [[nodiscard]] const Impl& impl() const { return *impl_; }
  [[nodiscard]] Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace cariesim
