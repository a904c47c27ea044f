#include "spheretree/build_support.hpp"

#include <openvdb/tools/Dense.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace cariesim::detail {

namespace {
// Largest coarse grid (voxels in the bounding box) the deep-distance fallback may use.
constexpr double kMaxCoarseVoxels = 4.0e6;
// The coarse grid is at least this many fine voxels per coarse voxel.
constexpr double kCoarseFactor = 4.0;
}  // namespace

// Picks triangles by cumulative area, then a uniform point inside each (square-root barycentrics).
std::vector<Vec3> sample_surface(const TriangleMesh& mesh, std::size_t count, uint64_t seed) {
  std::vector<Vec3> out;
  if (mesh.triangles.empty() || count == 0) return out;
  std::vector<double> cumulative(mesh.triangles.size());
  double total = 0.0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& t = mesh.triangles[i];
    const Vec3 a = mesh.vertices[t[0]].cast<double>();
    const Vec3 b = mesh.vertices[t[1]].cast<double>();
    const Vec3 c = mesh.vertices[t[2]].cast<double>();
    total += 0.5 * (b - a).cross(c - a).norm();
    cumulative[i] = total;
  }
  if (!(total > 0.0)) return out;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  out.reserve(count);
  for (std::size_t s = 0; s < count; ++s) {
    const double pick = unit(rng) * total;
    const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), pick);
    const std::size_t i =
        std::min<std::size_t>(static_cast<std::size_t>(it - cumulative.begin()), cumulative.size() - 1);
    const auto& t = mesh.triangles[i];
    const double u = std::sqrt(unit(rng));
    const double v = unit(rng);
    out.push_back((1.0 - u) * mesh.vertices[t[0]].cast<double>() +
                  u * (1.0 - v) * mesh.vertices[t[1]].cast<double>() +
                  u * v * mesh.vertices[t[2]].cast<double>());
  }
  return out;
}

// One pass over the triangles: each gets its expected number of points, rounded at random.
std::vector<Vec3> sample_surface_stratified(const TriangleMesh& mesh, double density, uint64_t seed) {
  std::vector<Vec3> out;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]].cast<double>();
    const Vec3 b = mesh.vertices[t[1]].cast<double>();
    const Vec3 c = mesh.vertices[t[2]].cast<double>();
    const double expected = 0.5 * (b - a).cross(c - a).norm() * density;
    const auto n = static_cast<int>(std::floor(expected + unit(rng)));
    for (int k = 0; k < n; ++k) {
      const double u = std::sqrt(unit(rng));
      const double v = unit(rng);
      out.push_back((1.0 - u) * a + u * (1.0 - v) * b + u * v * c);
    }
  }
  return out;
}

std::vector<Vec3> sample_surface_band(const TriangleMesh& mesh,
                                      const std::function<double(const Vec3&)>& band, double half_width,
                                      std::size_t count, uint64_t seed) {
  std::vector<Vec3> out;
  if (mesh.triangles.empty() || count == 0) return out;
  // Triangles that may reach the band: |band| is 1-Lipschitz, so a triangle whose centroid lies
  // further from the band than the triangle's circumradius cannot.
  struct Candidate {
    Vec3 a, b, c;
    double area;
  };
  std::vector<Candidate> candidates;
  for (const auto& t : mesh.triangles) {
    Candidate k{mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(),
                mesh.vertices[t[2]].cast<double>(), 0.0};
    k.area = 0.5 * (k.b - k.a).cross(k.c - k.a).norm();
    const Vec3 centroid = (k.a + k.b + k.c) / 3.0;
    const double reach =
        std::max({(k.a - centroid).norm(), (k.b - centroid).norm(), (k.c - centroid).norm()});
    if (k.area > 0.0 && std::abs(band(centroid)) <= half_width + reach) candidates.push_back(k);
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto point_in = [&](const Candidate& k) {
    const double u = std::sqrt(unit(rng));
    const double v = unit(rng);
    return Vec3((1.0 - u) * k.a + u * (1.0 - v) * k.b + u * v * k.c);
  };
  // The band's area, from a coarse pass (at least 16 points per candidate triangle).
  constexpr double kProbeDensity = 16.0;  // points per mm^2
  double band_area = 0.0;
  for (const Candidate& k : candidates) {
    const int n = std::max(16, static_cast<int>(std::ceil(k.area * kProbeDensity)));
    int in = 0;
    for (int i = 0; i < n; ++i) in += std::abs(band(point_in(k))) <= half_width ? 1 : 0;
    band_area += k.area * in / n;
  }
  if (!(band_area > 0.0)) return out;
  // The density that puts about `count` points in the band.
  const double density = static_cast<double>(count) / band_area;
  for (const Candidate& k : candidates) {
    const auto n = static_cast<std::size_t>(std::floor(k.area * density + unit(rng)));
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 p = point_in(k);
      if (std::abs(band(p)) <= half_width) out.push_back(p);
    }
  }
  return out;
}

// The coarse fallback: the fine field sampled on coarse voxels over the whole box (exact near the
// surface, clamped deeper), meshed (volumeToMesh), and that light mesh turned back into a level set
// whose bands reach the needed distances (meshToVolume computes exact distances to the mesh).
DistanceField::DistanceField(const LevelSet& shape, double needed_depth_mm, double needed_outside_mm,
                             double min_coarse_voxel_mm)
    : fine_(*shape.impl().grid), voxel_(shape.voxel_size()) {
  const double band = shape.half_band();
  reliable_ = std::max(band - 1.5 * voxel_, 0.5 * voxel_);
  if (needed_depth_mm <= reliable_ && needed_outside_mm <= reliable_) return;
  const Eigen::AlignedBox3d box = shape.bounds();
  const Vec3 extent = box.sizes();
  const double coarse_voxel =
      std::max({kCoarseFactor * voxel_, std::cbrt(extent.prod() / kMaxCoarseVoxels), min_coarse_voxel_mm});
  const auto transform = openvdb::math::Transform::createLinearTransform(coarse_voxel);

  // Sample the fine field densely on the coarse voxels (parallel, into a dense block, then sparse).
  auto sampled = openvdb::FloatGrid::create(static_cast<float>(band));
  sampled->setTransform(transform);
  sampled->setGridClass(openvdb::GRID_LEVEL_SET);
  {
    const Eigen::Vector3i lo = (box.min() / coarse_voxel).array().floor().cast<int>().matrix();
    const Eigen::Vector3i hi = (box.max() / coarse_voxel).array().ceil().cast<int>().matrix();
    const openvdb::CoordBBox bbox(openvdb::Coord(lo.x(), lo.y(), lo.z()),
                                  openvdb::Coord(hi.x(), hi.y(), hi.z()));
    openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(bbox);
    const openvdb::Coord dim = bbox.dim();
    tbb::parallel_for(tbb::blocked_range<int>(0, dim.x()), [&](const tbb::blocked_range<int>& range) {
      GridSampler fine(fine_);
      for (int i = range.begin(); i != range.end(); ++i) {
        for (int j = 0; j < dim.y(); ++j) {
          for (int k = 0; k < dim.z(); ++k) {
            const openvdb::Coord ijk(lo.x() + i, lo.y() + j, lo.z() + k);
            const double d = fine.distance(Vec3(ijk.x(), ijk.y(), ijk.z()) * coarse_voxel);
            dense.setValue(ijk, static_cast<float>(std::clamp(d, -band, band)));
          }
        }
      }
    });
    openvdb::tools::copyFromDense(dense, *sampled, -1.0f);
  }

  // Mesh it and rebuild with wide bands.
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*sampled, points, triangles, quads, 0.0, 0.0);
  if (points.empty()) return;
  for (const auto& t : triangles) quads.emplace_back(t[0], t[1], t[2], openvdb::util::INVALID_IDX);
  // meshToVolume reads index-space points.
  for (auto& p : points) p = transform->worldToIndex(p);
  const double depth = std::min(needed_depth_mm, 0.5 * extent.minCoeff()) + coarse_voxel;
  const double outside = std::max(needed_outside_mm, 0.0) + coarse_voxel;
  const openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec4I> mesh(points, quads);
  coarse_ = openvdb::tools::meshToVolume<openvdb::FloatGrid>(mesh, *transform,
                                                             static_cast<float>(outside / coarse_voxel + 2.0),
                                                             static_cast<float>(depth / coarse_voxel + 2.0));
}

DistanceField::Probe::Probe(const DistanceField& field) : field_(field), fine_(field.fine_) {
  if (field.coarse_) coarse_.emplace(*field.coarse_);
}

double DistanceField::Probe::distance(const Vec3& p) {
  const double d = fine_.distance(p);
  if (!coarse_ || std::abs(d) < field_.reliable_) return d;
  // The fine grid only says |d| >= reliable band; the coarse grid says how much more.
  const double dc = coarse_->distance(p);
  return d < 0.0 ? std::min(dc, -field_.reliable_) : std::max(dc, field_.reliable_);
}

Vec3 DistanceField::Probe::gradient(const Vec3& p) {
  const double h = 0.5 * field_.voxel_;
  Vec3 g;
  for (int axis = 0; axis < 3; ++axis) {
    Vec3 step = Vec3::Zero();
    step[axis] = h;
    g[axis] = distance(p + step) - distance(p - step);
  }
  const double n = g.norm();
  return n > 0.0 ? Vec3(g / n) : Vec3::Zero();
}

PointIndex::PointIndex(const std::vector<Vec3>& points, double cell_mm) : array_{&points} {
  ensure_openvdb_initialized();
  grid_ = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(array_, cell_mm);
}

}  // namespace cariesim::detail
