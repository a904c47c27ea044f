#include "geometry/implicit_mesher.hpp"

#include <fmt/format.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <cmath>

#include "cariesim/common/error.hpp"

namespace cariesim {

namespace {
// Half width of the narrow band kept around the surface, in voxels.
constexpr double kBandVoxels = 3.0;
// OpenVDB leaf nodes hold 8^3 voxels; blocks of that size are sampled or skipped whole.
constexpr int kBlock = 8;
}  // namespace

TriangleMesh mesh_implicit(const ImplicitFn& f, const Eigen::AlignedBox3d& box, double voxel_mm,
                           double lipschitz, const std::string& what) {
  if (!(voxel_mm > 0.0) || !std::isfinite(voxel_mm) || box.isEmpty() || !box.sizes().allFinite()) {
    throw Error(fmt::format("{}: invalid sampling (voxel {} mm)", what, voxel_mm));
  }
  const double cells = (box.sizes() / voxel_mm).prod();
  if (cells > 2e9) throw Error(fmt::format("{}: resolution {} mm is too fine for this size", what, voxel_mm));

  openvdb::initialize();
  const auto band = static_cast<float>(kBandVoxels * voxel_mm);
  auto grid = openvdb::FloatGrid::create(band);
  // Samples sit off the round coordinates (by a fixed fraction of a voxel) so that flat faces of a
  // shape, such as a plane at z = 0, never pass exactly through them: exact zeros make the mesher
  // emit collapsed polygons.
  const Vec3 offset = Vec3(0.1372, 0.2718, 0.3141) * voxel_mm;
  auto transform = openvdb::math::Transform::createLinearTransform(voxel_mm);
  transform->postTranslate(openvdb::Vec3d(offset.x(), offset.y(), offset.z()));
  grid->setTransform(transform);
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  auto& tree = grid->tree();
  auto acc = grid->getAccessor();

  // Index range of the box, padded by a voxel and aligned to blocks.
  openvdb::Coord lo;
  openvdb::Coord hi;
  for (int k = 0; k < 3; ++k) {
    lo[k] = static_cast<int>(std::floor(box.min()[k] / voxel_mm)) - 1;
    hi[k] = static_cast<int>(std::ceil(box.max()[k] / voxel_mm)) + 1;
    lo[k] = lo[k] >= 0 ? lo[k] / kBlock * kBlock : -((-lo[k] + kBlock - 1) / kBlock) * kBlock;
  }

  // Per block: far outside stays background (+band), far inside becomes an inactive -band tile, and
  // blocks that may hold surface are sampled voxel by voxel (values clamped to the band).
  const double reach = band + lipschitz * (std::sqrt(3.0) * 0.5 * kBlock * voxel_mm);
  for (int bz = lo.z(); bz <= hi.z(); bz += kBlock) {
    for (int by = lo.y(); by <= hi.y(); by += kBlock) {
      for (int bx = lo.x(); bx <= hi.x(); bx += kBlock) {
        const Vec3 centre = (Vec3(bx, by, bz) + Vec3::Constant(0.5 * (kBlock - 1))) * voxel_mm + offset;
        const double fc = f(centre);
        if (fc > reach) continue;
        if (fc < -reach) {
          tree.addTile(1, openvdb::Coord(bx, by, bz), -band, false);
          continue;
        }
        for (int z = bz; z < bz + kBlock; ++z) {
          for (int y = by; y < by + kBlock; ++y) {
            for (int x = bx; x < bx + kBlock; ++x) {
              const double v = f(Vec3(x, y, z) * voxel_mm + offset);
              const openvdb::Coord ijk(x, y, z);
              if (std::abs(v) < band) {
                acc.setValueOn(ijk, static_cast<float>(v));
              } else {
                acc.setValueOff(ijk, v < 0.0 ? -band : band);
              }
            }
          }
        }
      }
    }
  }

  // Zero set as quads and triangles; quads are split along their shorter diagonal.
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, triangles, quads, 0.0, 0.0, true);
  TriangleMesh mesh;
  mesh.vertices.reserve(points.size());
  for (const auto& p : points) mesh.vertices.emplace_back(p.x(), p.y(), p.z());
  mesh.triangles.reserve(triangles.size() + 2 * quads.size());
  for (const auto& t : triangles) mesh.triangles.push_back({t[0], t[1], t[2]});
  for (const auto& q : quads) {
    const float d02 = (mesh.vertices[q[0]] - mesh.vertices[q[2]]).squaredNorm();
    const float d13 = (mesh.vertices[q[1]] - mesh.vertices[q[3]]).squaredNorm();
    if (d02 <= d13) {
      mesh.triangles.push_back({q[0], q[1], q[2]});
      mesh.triangles.push_back({q[0], q[2], q[3]});
    } else {
      mesh.triangles.push_back({q[0], q[1], q[3]});
      mesh.triangles.push_back({q[1], q[2], q[3]});
    }
  }

  // Checked like any input mesh (and wound outward).
  MeshLoadOptions options;
  options.check_self_intersections = false;
  options.fill_small_holes = false;
  validate_mesh(mesh, what, nullptr, options);
  return mesh;
}

}  // namespace cariesim
