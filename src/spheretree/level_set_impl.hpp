#pragma once
// The OpenVDB side of LevelSet, shared by the spheretree sources only (never a public header).

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include "cariesim/spheretree/level_set.hpp"

namespace cariesim {

struct LevelSet::Impl {
  openvdb::FloatGrid::Ptr grid;  ///< level set grid (world-unit distances, negative inside)
};

/// Initialises OpenVDB's type registry once (thread-safe).
void ensure_openvdb_initialized();

/// Trilinear sampling of a float grid through an unregistered accessor: cheap to create, so every
/// thread (or call) can own one, which keeps const queries thread-safe.
class GridSampler {
 public:
  using Accessor = openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>;
  explicit GridSampler(const openvdb::FloatGrid& grid)
      : accessor_(grid.tree()), transform_(grid.transform()) {}
  /// Distance (mm) at a world point, trilinear.
  [[nodiscard]] double distance(const Vec3& p) {
    const openvdb::Vec3d index = transform_.worldToIndex(openvdb::Vec3d(p.x(), p.y(), p.z()));
    return openvdb::tools::BoxSampler::sample(accessor_, index);
  }

 private:
  Accessor accessor_;
  const openvdb::math::Transform& transform_;
};

}  // namespace cariesim
