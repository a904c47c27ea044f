#include "cariesim/spheretree/level_set.hpp"

#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <cmath>
#include <mutex>
#include <string>

#include "cariesim/common/error.hpp"
#include "spheretree/level_set_impl.hpp"

namespace cariesim {

void ensure_openvdb_initialized() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

namespace {

// Checks a voxel size and band width given to a level-set constructor.
void check_grid_params(double voxel_mm, double half_band_mm, const char* where) {
  if (!(voxel_mm > 0.0) || !std::isfinite(voxel_mm)) {
    throw Error(std::string(where) + ": voxel size must be a positive number of mm, got " +
                std::to_string(voxel_mm));
  }
  if (!(half_band_mm >= voxel_mm) || !std::isfinite(half_band_mm)) {
    throw Error(std::string(where) + ": half band must be at least one voxel (" + std::to_string(voxel_mm) +
                " mm), got " + std::to_string(half_band_mm) + " mm");
  }
}

// Rebuilds `grid` on `target`'s voxels and band so that the two can be combined voxel by voxel.
openvdb::FloatGrid::Ptr match_grid(const openvdb::FloatGrid& grid, const openvdb::FloatGrid& target) {
  const double voxel = target.voxelSize()[0];
  const bool same_transform = grid.transform() == target.transform();
  const bool same_band = std::abs(grid.background() - target.background()) <= 1e-6 * voxel;
  if (same_transform && same_band) return nullptr;
  const auto band_voxels = static_cast<float>(target.background() / voxel);
  return openvdb::tools::levelSetRebuild(grid, 0.0f, band_voxels, band_voxels, &target.transform());
}

// Wraps a grid into a LevelSet (the grid becomes owned by it).
LevelSet wrap(openvdb::FloatGrid::Ptr grid) {
  LevelSet out;
  out.impl().grid = std::move(grid);
  return out;
}

}  // namespace

LevelSet::LevelSet() : impl_(std::make_unique<Impl>()) {}
LevelSet::~LevelSet() = default;
LevelSet::LevelSet(const LevelSet& other) : impl_(std::make_unique<Impl>()) {
  if (other.impl_->grid) impl_->grid = other.impl_->grid->deepCopy();
}
LevelSet& LevelSet::operator=(const LevelSet& other) {
  if (this != &other) {
    impl_->grid = other.impl_->grid ? other.impl_->grid->deepCopy() : nullptr;
  }
  return *this;
}
LevelSet::LevelSet(LevelSet&& other) noexcept : impl_(std::make_unique<Impl>()) {
  impl_->grid = std::move(other.impl_->grid);
}
LevelSet& LevelSet::operator=(LevelSet&& other) noexcept {
  impl_->grid = std::move(other.impl_->grid);
  return *this;
}

// Mesh -> narrow-band level set (OpenVDB meshToLevelSet: exact distances in the band, sign by flood fill).
LevelSet LevelSet::from_mesh(const TriangleMesh& mesh, double voxel_mm, double half_band_mm) {
  check_grid_params(voxel_mm, half_band_mm, "LevelSet::from_mesh");
  if (mesh.triangles.empty()) throw Error("LevelSet::from_mesh: the mesh has no triangles");
  ensure_openvdb_initialized();

  // Copy the mesh into OpenVDB's types, rejecting bad indices and coordinates.
  std::vector<openvdb::Vec3s> points;
  points.reserve(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3f& v = mesh.vertices[i];
    if (!v.allFinite()) {
      throw Error("LevelSet::from_mesh: vertex " + std::to_string(i) + " has a non-finite coordinate");
    }
    points.emplace_back(v.x(), v.y(), v.z());
  }
  std::vector<openvdb::Vec3I> triangles;
  triangles.reserve(mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& t = mesh.triangles[i];
    for (uint32_t index : t) {
      if (index >= points.size()) {
        throw Error("LevelSet::from_mesh: triangle " + std::to_string(i) + " refers to vertex " +
                    std::to_string(index) + " of " + std::to_string(points.size()));
      }
    }
    triangles.emplace_back(t[0], t[1], t[2]);
  }

  auto transform = openvdb::math::Transform::createLinearTransform(voxel_mm);
  auto grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*transform, points, triangles,
                                                                 static_cast<float>(half_band_mm / voxel_mm));
  if (grid->activeVoxelCount() == 0) {
    throw Error("LevelSet::from_mesh: the mesh produced an empty level set (voxel " +
                std::to_string(voxel_mm) + " mm is too coarse, or the mesh is degenerate)");
  }
  return wrap(std::move(grid));
}

// CSG on level sets (paper §2.2): the other operand is rebuilt on this grid's voxels when they differ.
LevelSet LevelSet::united(const LevelSet& other) const {
  if (empty()) return other;
  if (other.empty()) return *this;
  const auto matched = match_grid(*other.impl_->grid, *impl_->grid);
  return wrap(openvdb::tools::csgUnionCopy(*impl_->grid, matched ? *matched : *other.impl_->grid));
}

LevelSet LevelSet::intersection(const LevelSet& other) const {
  if (empty() || other.empty()) return LevelSet();
  const auto matched = match_grid(*other.impl_->grid, *impl_->grid);
  return wrap(openvdb::tools::csgIntersectionCopy(*impl_->grid, matched ? *matched : *other.impl_->grid));
}

LevelSet LevelSet::difference(const LevelSet& other) const {
  if (empty() || other.empty()) return *this;
  const auto matched = match_grid(*other.impl_->grid, *impl_->grid);
  return wrap(openvdb::tools::csgDifferenceCopy(*impl_->grid, matched ? *matched : *other.impl_->grid));
}

double LevelSet::distance(const Vec3& p) const {
  if (empty()) return std::numeric_limits<double>::infinity();
  GridSampler sampler(*impl_->grid);
  return sampler.distance(p);
}

// Central differences of the trilinear field over half a voxel, normalised.
Vec3 LevelSet::gradient(const Vec3& p) const {
  if (empty()) return Vec3::Zero();
  GridSampler sampler(*impl_->grid);
  const double h = 0.5 * voxel_size();
  Vec3 g;
  for (int axis = 0; axis < 3; ++axis) {
    Vec3 step = Vec3::Zero();
    step[axis] = h;
    g[axis] = sampler.distance(p + step) - sampler.distance(p - step);
  }
  const double n = g.norm();
  return n > 0.0 ? Vec3(g / n) : Vec3::Zero();
}

Eigen::AlignedBox3d LevelSet::bounds() const {
  if (empty()) return Eigen::AlignedBox3d(Vec3::Zero(), Vec3::Zero());
  const openvdb::CoordBBox box = impl_->grid->evalActiveVoxelBoundingBox();
  const openvdb::Vec3d lo = impl_->grid->indexToWorld(box.min());
  const openvdb::Vec3d hi = impl_->grid->indexToWorld(box.max());
  return Eigen::AlignedBox3d(Vec3(lo.x(), lo.y(), lo.z()), Vec3(hi.x(), hi.y(), hi.z()));
}

double LevelSet::voxel_size() const { return impl_->grid ? impl_->grid->voxelSize()[0] : 0.0; }

double LevelSet::half_band() const { return impl_->grid ? impl_->grid->background() : 0.0; }

bool LevelSet::empty() const { return !impl_->grid || impl_->grid->activeVoxelCount() == 0; }

// Zero iso-surface through volumeToMesh; quads split into triangles, winding made outward.
TriangleMesh LevelSet::to_mesh(double adaptivity) const {
  TriangleMesh mesh;
  if (empty()) return mesh;
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*impl_->grid, points, triangles, quads, 0.0, adaptivity);

  mesh.vertices.reserve(points.size());
  for (const auto& p : points) mesh.vertices.emplace_back(p.x(), p.y(), p.z());
  mesh.triangles.reserve(triangles.size() + 2 * quads.size());
  for (const auto& t : triangles) mesh.triangles.push_back({t[0], t[1], t[2]});
  for (const auto& q : quads) {
    mesh.triangles.push_back({q[0], q[1], q[2]});
    mesh.triangles.push_back({q[0], q[2], q[3]});
  }

  // A negative enclosed volume means inward winding: flip it.
  if (mesh.volume() < 0.0) {
    for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  }
  return mesh;
}

}  // namespace cariesim
