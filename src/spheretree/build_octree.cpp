// Octree sphere trees, the paper's fidelity mode (paper §2.2, "level 4 with 4096 spheres"): the
// object's bounding cube split 2x2x2 per level; a cell is kept when it holds surface
// (|D(centre)| <= half diagonal) or lies inside (D(centre) < 0); its sphere is centred in the cell
// with radius (sqrt(3)/2) * edge, so every child sphere lies inside its parent's sphere. The builder
// makes the leaf cells; build_octree_hierarchy puts the cells above them back from their paths.

#include <cmath>
#include <string>
#include <vector>

#include "cariesim/common/error.hpp"
#include "spheretree/build_support.hpp"

namespace cariesim::detail {

namespace {

// Bits of a cell's path per level (the octant).
constexpr int kBitsPerLevel = 3;
// mm: how far a leaf sphere may reach out of its cell's sphere (float rounding of both).
constexpr double kCellSlack = 1e-4;

// A kept cell of one level: its centre, its path from the root and whether it holds surface.
struct Cell {
  Vec3 center;
  uint32_t path = 0;
  bool surface = false;
};

// Radius (mm) of the sphere around a cell of `level` (the root is level 0): (sqrt(3)/2) * edge.
double cell_radius(double root_edge, int level) {
  return 0.5 * std::sqrt(3.0) * root_edge / std::ldexp(1.0, level);
}

// Centre (mm) of the child of a cell centred at `parent` in `octant` (bit 0 +x, bit 1 +y, bit 2 +z),
// the child's edge `child_edge` (mm). The builder and the hierarchy compute it alike, to the bit.
Vec3 child_center(const Vec3& parent, double child_edge, uint32_t octant) {
  const Vec3 offset((octant & 1) ? 0.25 : -0.25, (octant & 2) ? 0.25 : -0.25, (octant & 4) ? 0.25 : -0.25);
  return parent + 2.0 * child_edge * offset;
}

// Rejects octree cells that are not those of the leaves, naming the first wrong one.
void check_cells(const TreeLeaves& in) {
  const OctreeFrame& f = in.octree;
  const auto fail = [](const std::string& what) { throw Error("build_tree: octree: " + what); };
  if (in.cells.size() != in.leaves.size()) {
    fail(std::to_string(in.cells.size()) + " cells for " + std::to_string(in.leaves.size()) + " leaves");
  }
  if (f.depth < 0 || f.depth > kMaxOctreeDepth) {
    fail("depth " + std::to_string(f.depth) + " is outside [0, " + std::to_string(kMaxOctreeDepth) + "]");
  }
  if (!f.center.allFinite() || !(f.edge > 0.0) || !std::isfinite(f.edge)) {
    fail("the root cell needs a finite centre and a positive edge (mm)");
  }
  const uint64_t cell_count = uint64_t{1} << (kBitsPerLevel * f.depth);
  for (std::size_t i = 0; i < in.cells.size(); ++i) {
    if (in.cells[i] >= cell_count) {
      fail("leaf " + std::to_string(i) + ": cell " + std::to_string(in.cells[i]) +
           " is not a cell of depth " + std::to_string(f.depth));
    }
    if (i > 0 && in.cells[i] <= in.cells[i - 1]) {
      fail("leaf " + std::to_string(i) + ": cell " + std::to_string(in.cells[i]) +
           " does not follow the previous leaf's (cells must increase)");
    }
  }
}

}  // namespace

TreeLeaves build_octree_leaves(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress) {
  TreeLeaves out;
  out.mode = TreeMode::Octree;
  report(progress, "octree: bounds", 0.0);
  const TriangleMesh surface = shape.to_mesh(0.0);
  if (surface.triangles.empty()) return out;
  const double voxel = shape.voxel_size();

  // The bounding cube of the zero set, padded by a voxel so that surface on the box still lies inside.
  const Eigen::AlignedBox3d box = surface.bounds();
  const double root_edge = box.sizes().maxCoeff() + 2.0 * voxel;
  const double leaf_half_diagonal = cell_radius(root_edge, params.depth);
  // A cell holds surface when |D(centre)| <= half diagonal; one voxel of slack absorbs the level
  // set's own error, so that no cell touched by the input surface is lost.
  const double slack = voxel;
  const DistanceField field(shape, 0.5 * root_edge, leaf_half_diagonal + 2.0 * slack);
  DistanceField::Probe probe(field);

  // Level by level: the children of every kept cell, kept when they hold surface or lie inside. The
  // children of a cell are appended together in octant order, so every level is in path order.
  std::vector<Cell> cells{{box.center(), 0, true}};
  for (int level = 0; level < params.depth; ++level) {
    report(progress, "octree: level", static_cast<double>(level) / params.depth);
    const double child_edge = root_edge / std::ldexp(1.0, level + 1);
    const double child_half_diagonal = 0.5 * std::sqrt(3.0) * child_edge;
    std::vector<Cell> children;
    for (const Cell& parent : cells) {
      for (uint32_t octant = 0; octant < 8; ++octant) {
        const Vec3 center = child_center(parent.center, child_edge, octant);
        const double d = probe.distance(center);
        const bool surface_cell = std::abs(d) <= child_half_diagonal + slack;
        if (d < 0.0 || surface_cell)
          children.push_back({center, (parent.path << kBitsPerLevel) | octant, surface_cell});
      }
    }
    cells = std::move(children);
  }

  // The leaves: the kept cells of the deepest level (the levels above are their ancestors).
  out.octree = {box.center(), root_edge, params.depth};
  const auto radius = static_cast<float>(cell_radius(root_edge, params.depth));
  out.leaves.reserve(cells.size());
  out.cells.reserve(cells.size());
  for (const Cell& cell : cells) {
    LeafSphere leaf{};
    leaf.center = cell.center.cast<float>();
    leaf.radius = radius;
    leaf.flags = cell.surface ? kLeafOnExposedSurface : kLeafInterior;
    leaf.depth = static_cast<float>(-probe.distance(cell.center));
    out.leaves.push_back(leaf);
    out.cells.push_back(cell.path);
  }
  report(progress, "octree: done", 1.0);
  return out;
}

SphereTree build_octree_hierarchy(const TreeLeaves& in) {
  check_cells(in);
  if (in.leaves.empty()) return {};
  const OctreeFrame& frame = in.octree;
  const auto depth = static_cast<std::size_t>(frame.depth);

  // The paths of every level's cells, bottom up: a level's cells are the distinct prefixes of the
  // level below (in order, since the leaves' paths increase).
  std::vector<std::vector<uint32_t>> paths(depth + 1);
  paths[depth] = in.cells;
  for (std::size_t level = depth; level-- > 0;) {
    for (const uint32_t child : paths[level + 1]) {
      const uint32_t path = child >> kBitsPerLevel;
      if (paths[level].empty() || paths[level].back() != path) paths[level].push_back(path);
    }
  }

  // Flat layout, level by level; the children of a cell are contiguous because their paths share
  // its prefix. Centres top down from the root, as the builder found them.
  SphereTree tree;
  tree.mode = TreeMode::Octree;
  tree.levels = frame.depth + 1;
  std::vector<uint32_t> level_offset(depth + 1, 0);
  std::size_t total = 0;
  for (std::size_t level = 0; level <= depth; ++level) {
    level_offset[level] = static_cast<uint32_t>(total);
    total += paths[level].size();
  }
  tree.nodes.resize(total);
  tree.leaf_nodes.resize(in.leaves.size());
  tree.leaf_depth.resize(in.leaves.size());
  tree.leaf_tangents.resize(in.leaves.size());
  std::vector<Vec3> centers;  // mm, the cells of the level above
  for (std::size_t level = 0; level <= depth; ++level) {
    const double radius = cell_radius(frame.edge, static_cast<int>(level));
    const double edge = frame.edge / std::ldexp(1.0, static_cast<int>(level));
    std::vector<Vec3> level_centers(paths[level].size());
    uint32_t parent = 0;
    for (uint32_t i = 0; i < paths[level].size(); ++i) {
      const uint32_t path = paths[level][i];
      const uint32_t index = level_offset[level] + i;
      SphereNode& node = tree.nodes[index];
      if (level > 0) {
        while (paths[level - 1][parent] != path >> kBitsPerLevel) ++parent;
        level_centers[i] = child_center(centers[parent], edge, path & 7u);
        SphereNode& up = tree.nodes[level_offset[level - 1] + parent];
        if (up.count == 0) up.first = index;
        ++up.count;
      } else {
        level_centers[i] = frame.center;
      }
      if (level < depth) {
        node.center = level_centers[i].cast<float>();
        node.radius = static_cast<float>(radius);
        continue;
      }
      // A leaf: the builder's sphere, which must lie in its cell's.
      const LeafSphere& leaf = in.leaves[i];
      const double reach = (leaf.center.cast<double>() - level_centers[i]).norm() + leaf.radius;
      if (!(reach <= radius + kCellSlack) || !(leaf.radius >= 0.0f)) {
        throw Error("build_tree: octree: leaf " + std::to_string(i) + " does not lie in its cell " +
                    std::to_string(path) + " (it reaches " + std::to_string(reach) +
                    " mm from the cell's centre, " + std::to_string(radius) + " mm allowed)");
      }
      node.center = leaf.center;
      node.radius = leaf.radius;
      node.material = leaf.material;
      node.flags = leaf.flags;
      node.leaf = i;
      tree.leaf_nodes[i] = index;
      tree.leaf_depth[i] = leaf.depth;
      tree.leaf_tangents[i] = leaf.tangents;
    }
    centers = std::move(level_centers);
  }
  return tree;
}

}  // namespace cariesim::detail
