#pragma once
// Private helpers of the tree builders and the deviation measure: surface sampling, a signed distance
// that stays meaningful beyond the narrow band, and radius queries over point sets.

#include <openvdb/tools/PointIndexGrid.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "cariesim/common/progress.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/level_set.hpp"
#include "spheretree/level_set_impl.hpp"

namespace cariesim::detail {

/// The two builders behind build_leaves (parameters already checked).
TreeLeaves build_tight_leaves(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress);
TreeLeaves build_octree_leaves(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress);

/// build_tree for an octree: the cells above the leaves (`leaves.cells` checked here).
SphereTree build_octree_hierarchy(const TreeLeaves& leaves);

/// Deepest octree the builder accepts (8^7 ~ 2 million leaves; a cell's path fits 21 bits).
inline constexpr int kMaxOctreeDepth = 7;

/// `count` points distributed uniformly by area over the mesh (seeded, deterministic).
std::vector<Vec3> sample_surface(const TriangleMesh& mesh, std::size_t count, uint64_t seed);

/// About `density` points per mm^2, stratified by triangle (each gets floor(area * density + u),
/// u uniform in [0, 1)), so the points come out grouped triangle by triangle (seeded, deterministic).
std::vector<Vec3> sample_surface_stratified(const TriangleMesh& mesh, double density, uint64_t seed);

/// About `count` points distributed uniformly by area over the part of the mesh where |band(x)| <=
/// `half_width` (mm); `band` must be 1-Lipschitz (a signed distance). Seeded, deterministic.
std::vector<Vec3> sample_surface_band(const TriangleMesh& mesh,
                                      const std::function<double(const Vec3&)>& band, double half_width,
                                      std::size_t count, uint64_t seed);

/// Signed distance of a level set's zero set, negative inside. Within the narrow band it is the level
/// set's trilinear value; where that saturates it falls back on a coarser level set of the same
/// surface with wide bands (OpenVDB volumeToMesh + meshToVolume), so deep points still get a
/// distance instead of the band width. The fallback is good to about 0.15 coarse voxels (0.03 mm
/// for a tooth at 0.05 mm voxels): callers that need more check against surface samples.
class DistanceField {
 public:
  /// `needed_depth_mm` / `needed_outside_mm`: the largest distances inside / outside the caller must
  /// resolve; no coarse grid is built when the narrow band already covers both. The coarse voxel is
  /// 4 fine voxels, or `min_coarse_voxel_mm` when larger, or larger still to stay within budget.
  DistanceField(const LevelSet& shape, double needed_depth_mm, double needed_outside_mm = 0.0,
                double min_coarse_voxel_mm = 0.0);

  /// Per-thread sampler (its accessors cache tree nodes, so one per thread).
  class Probe {
   public:
    explicit Probe(const DistanceField& field);
    /// Signed distance (mm).
    double distance(const Vec3& p);
    /// Unit gradient by central differences over half a fine voxel (zero where undefined).
    Vec3 gradient(const Vec3& p);

   private:
    const DistanceField& field_;
    GridSampler fine_;
    std::optional<GridSampler> coarse_;
  };

  [[nodiscard]] double voxel() const { return voxel_; }
  /// |distance| below this comes from the fine grid (mm).
  [[nodiscard]] double reliable_band() const { return reliable_; }

 private:
  const openvdb::FloatGrid& fine_;
  openvdb::FloatGrid::Ptr coarse_;
  double voxel_ = 0.0;
  double reliable_ = 0.0;
};

/// Adapts a point vector to OpenVDB's PointArray interface.
struct PointArray {
  using PosType = openvdb::Vec3R;
  using value_type = openvdb::Vec3R;
  const std::vector<Vec3>* points;
  [[nodiscard]] std::size_t size() const { return points->size(); }
  void getPos(std::size_t n, openvdb::Vec3R& xyz) const {
    const Vec3& p = (*points)[n];
    xyz = openvdb::Vec3R(p.x(), p.y(), p.z());
  }
};

/// Radius queries over a fixed set of points (OpenVDB PointIndexGrid).
class PointIndex {
 public:
  /// `cell_mm`: bucket size, about the typical query radius.
  PointIndex(const std::vector<Vec3>& points, double cell_mm);

  /// A per-thread query handle.
  class Query {
   public:
    explicit Query(const PointIndex& index) : index_(index), accessor_(index.grid_->tree()) {}
    /// Calls f(i) for every point i within `radius` of `center`.
    template <typename F>
    void for_each_within(const Vec3& center, double radius, F&& f) {
      iterator_.worldSpaceSearchAndUpdate(openvdb::Vec3d(center.x(), center.y(), center.z()), radius,
                                          accessor_, index_.array_, index_.grid_->transform());
      for (; iterator_; ++iterator_) f(static_cast<std::size_t>(*iterator_));
    }

   private:
    const PointIndex& index_;
    openvdb::tree::ValueAccessor<const openvdb::tools::PointIndexTree> accessor_;
    openvdb::tools::PointIndexIterator<> iterator_;
  };

 private:
  PointArray array_;
  openvdb::tools::PointIndexGrid::Ptr grid_;
};

}  // namespace cariesim::detail
