#include "cariesim/spheretree/build.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/hierarchy.hpp"
#include "spheretree/build_support.hpp"

namespace cariesim {

namespace {

// Voxel budget of a narrow-band level set (band voxels over the whole surface).
constexpr double kMaxBandVoxels = 2.0e7;
// Tight mode: voxel size per unit of tolerance (0.015 mm -> 0.05 mm, fine enough for tooth scans).
constexpr double kVoxelPerTolerance = 10.0 / 3.0;
// Octree mode: fine voxels per leaf cell edge.
constexpr double kVoxelsPerOctreeCell = 8.0;
// Half band in voxels.
constexpr double kBandVoxels = 5.0;
using detail::kMaxOctreeDepth;

// Rejects parameters a build cannot use, naming the field.
void check_params(const TreeParams& p) {
  const auto fail = [](const std::string& what) { throw Error("tree parameters: " + what); };
  if (p.mode == TreeMode::Octree && (p.depth < 0 || p.depth > kMaxOctreeDepth)) {
    fail(fmt::format("depth {} is outside [0, {}]", p.depth, kMaxOctreeDepth));
  }
  if (p.mode == TreeMode::Tight) {
    if (!(p.tolerance > 0.0) || !std::isfinite(p.tolerance)) {
      fail(fmt::format("tolerance must be a positive number of mm, got {}", p.tolerance));
    }
    if (!(p.min_radius >= 0.0) || !std::isfinite(p.min_radius)) {
      fail(fmt::format("min_radius must be a non-negative number of mm, got {}", p.min_radius));
    }
    if (!(p.max_radius > p.min_radius) || !std::isfinite(p.max_radius)) {
      fail(fmt::format("max_radius ({} mm) must be finite and larger than min_radius ({} mm)", p.max_radius,
                       p.min_radius));
    }
    if (p.max_leaves == 0) fail("max_leaves must be positive");
  }
  if (p.branching < 2 || p.branching > 8) fail(fmt::format("branching {} is outside [2, 8]", p.branching));
}

}  // namespace

LevelSetResolution choose_resolution(const TriangleMesh& mesh, const TreeParams& params) {
  const Eigen::AlignedBox3d box = mesh.bounds();
  const double area = mesh.area();
  if (box.isEmpty() || !(area > 0.0)) throw Error("choose_resolution: the mesh is empty or has no area");
  // What fidelity asks for.
  double voxel = 0.0;
  if (params.mode == TreeMode::Tight) {
    voxel = kVoxelPerTolerance * params.tolerance;
  } else {
    const int depth = std::clamp(params.depth, 0, kMaxOctreeDepth);
    voxel = box.sizes().maxCoeff() / std::ldexp(1.0, depth) / kVoxelsPerOctreeCell;
  }
  // What memory allows: band voxels ~ area / voxel^2 * (2 * kBandVoxels).
  voxel = std::max(voxel, std::sqrt(2.0 * kBandVoxels * area / kMaxBandVoxels));
  return {voxel, kBandVoxels * voxel};
}

TreeLeaves build_leaves(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress) {
  check_params(params);
  if (shape.empty()) {
    TreeLeaves none;
    none.mode = params.mode;
    return none;
  }
  TreeLeaves out = params.mode == TreeMode::Octree ? detail::build_octree_leaves(shape, params, progress)
                                                   : detail::build_tight_leaves(shape, params, progress);
  set_leaf_tangents(out.leaves, shape);
  return out;
}

// The inner levels, once: the octree's cells, or spheres fitted over the tight leaves.
SphereTree build_tree(const TreeLeaves& leaves, int branching) {
  if (leaves.mode == TreeMode::Octree) return detail::build_octree_hierarchy(leaves);
  if (!leaves.cells.empty()) throw Error("build_tree: a tight tree's leaves have no octree cells");
  SphereTree tree = build_hierarchy(leaves.leaves, branching);
  tree.mode = TreeMode::Tight;
  return tree;
}

SphereTree build_sphere_tree(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress) {
  return build_tree(build_leaves(shape, params, progress), params.branching);
}

// Surface leaves without tangents from their builder (the octree's cells) get one: the unit gradient
// of the solid's distance at their centre (a leaf's nearest surface point lies along it). Interior
// fillers have none. The tight builder records the surfaces each sphere actually touches, which stays
// right at an edge or in a thin layer, where the gradient at the centre points along a bisector; its
// leaves need no distance field.
void set_leaf_tangents(std::span<LeafSphere> leaves, const LevelSet& shape) {
  constexpr uint32_t kSurface = kLeafOnExposedSurface | kLeafOnLesionWall;
  const auto needs_tangent = [](const LeafSphere& l) {
    return (l.flags & kSurface) && l.tangents.count == 0;
  };
  if (std::none_of(leaves.begin(), leaves.end(), needs_tangent)) return;
  double max_radius = 0.0;
  for (const LeafSphere& l : leaves)
    if (l.flags & kSurface) max_radius = std::max(max_radius, double(l.radius));
  const detail::DistanceField field(shape, max_radius + 2.0 * shape.voxel_size());
  detail::DistanceField::Probe probe(field);
  for (LeafSphere& l : leaves) {
    if (!needs_tangent(l)) continue;
    const Vec3 g = probe.gradient(l.center.cast<double>());
    if (!(g.allFinite() && g.norm() > 0.5)) continue;
    l.tangents.normal[0] = g.normalized().cast<float>();
    l.tangents.count = 1;
  }
}

// Each tangent of a leaf lies either on the outer surface or on an internal boundary (a lesion wall),
// judged at its tangent point (centre + radius along the normal): at the rim of a lesion a wall leaf may
// reach the outer surface while being tangent to the wall. A leaf with any tangent on the outer surface
// is exposed, one with any tangent inside is on a lesion wall, both at once is possible (a sphere
// spanning a thin lesion from its top to its floor). Without tangents, a leaf built on its part's
// surface counts as exposed when its sphere reaches within `touch_mm` of the outer surface.
void classify_leaves(SphereTree& tree, const LevelSet& outer, double touch_mm) {
  if (tree.empty()) return;
  const double reach = std::max(touch_mm, 0.0);
  double max_radius = 0.0;
  for (uint32_t node : tree.leaf_nodes) max_radius = std::max(max_radius, double(tree.nodes[node].radius));
  const detail::DistanceField field(outer, max_radius + reach);
  detail::DistanceField::Probe probe(field);
  tree.leaf_depth.resize(tree.leaf_nodes.size());
  tree.leaf_tangents.resize(tree.leaf_nodes.size());
  for (std::size_t i = 0; i < tree.leaf_nodes.size(); ++i) {
    SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
    LeafTangents& tangents = tree.leaf_tangents[i];
    const Vec3 c = node.center.cast<double>();
    const double depth = -probe.distance(c);
    tree.leaf_depth[i] = static_cast<float>(depth);
    const bool was_surface = (node.flags & (kLeafOnExposedSurface | kLeafOnLesionWall)) != 0;
    bool outer_touch = false, inner_touch = false;
    tangents.wall_mask = 0;
    for (int k = 0; k < tangents.count; ++k) {
      const Vec3 point = c + tangents.normal[k].cast<double>() * node.radius;
      if (-probe.distance(point) <= reach) {
        outer_touch = true;
      } else {
        inner_touch = true;
        tangents.wall_mask |= static_cast<uint8_t>(1u << k);
      }
    }
    if (tangents.count == 0 && was_surface) (depth - node.radius <= reach ? outer_touch : inner_touch) = true;
    uint32_t flags = node.flags & ~(kLeafOnExposedSurface | kLeafOnLesionWall | kLeafInterior);
    if (was_surface && outer_touch) flags |= kLeafOnExposedSurface;
    if (was_surface && inner_touch) flags |= kLeafOnLesionWall;
    if (!(flags & (kLeafOnExposedSurface | kLeafOnLesionWall))) flags |= kLeafInterior;
    node.flags = flags;
  }
}

void assign_materials(SphereTree& tree,
                      const std::function<uint16_t(const Vec3& center, float depth)>& material_of) {
  for (std::size_t i = 0; i < tree.leaf_nodes.size(); ++i) {
    SphereNode& node = tree.nodes[tree.leaf_nodes[i]];
    const float depth = i < tree.leaf_depth.size() ? tree.leaf_depth[i] : 0.0f;
    node.material = material_of(node.center.cast<double>(), depth);
  }
}

TreeReport make_tree_report(const SphereTree& tree, double build_seconds, const Deviation& deviation) {
  TreeReport r;
  r.mode = tree.mode;
  r.leaves = tree.leaf_count();
  r.levels = tree.levels;
  r.nodes_per_level = tree.nodes_per_level();
  r.build_seconds = build_seconds;
  r.deviation = deviation;
  return r;
}

std::string format_tree_report_json(const TreeReport& r) {
  return fmt::format(R"({{"mode":"{}","leaves":{},"levels":{},"nodes_per_level":[{}],"build_seconds":{:.3f},)"
                     R"("deviation_mm":{{"p50":{:.4f},"p95":{:.4f},"max":{:.4f},"max_poke_out":{:.4f},)"
                     R"("max_fall_short":{:.4f},"samples":{}}}}})",
                     r.mode == TreeMode::Octree ? "octree" : "tight", r.leaves, r.levels,
                     fmt::join(r.nodes_per_level, ","), r.build_seconds, r.deviation.p50, r.deviation.p95,
                     r.deviation.max, r.deviation.max_poke_out, r.deviation.max_fall_short,
                     r.deviation.samples);
}

}  // namespace cariesim
