// Octree sphere trees, the paper's fidelity mode (paper §2.2, "level 4 with 4096 spheres"): the
// object's bounding cube split 2x2x2 per level; a cell is kept when it holds surface
// (|D(centre)| <= half diagonal) or lies inside (D(centre) < 0); its sphere is centred in the cell
// with radius (sqrt(3)/2) * edge, so every child sphere lies inside its parent's sphere.

#include <array>
#include <cmath>
#include <vector>

#include "spheretree/build_support.hpp"

namespace cariesim::detail {

namespace {

// A kept cell of one level: its centre, its parent's position in the previous level, and whether
// it holds surface.
struct Cell {
  Vec3 center;
  uint32_t parent = 0;
  bool surface = false;
  uint32_t kept_children = 0;
};

}  // namespace

SphereTree build_octree_tree(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress) {
  report(progress, "octree: bounds", 0.0);
  const TriangleMesh surface = shape.to_mesh(0.0);
  if (surface.triangles.empty()) return {};
  const double voxel = shape.voxel_size();

  // The bounding cube of the zero set, padded by a voxel so that surface on the box still lies inside.
  const Eigen::AlignedBox3d box = surface.bounds();
  const double root_edge = box.sizes().maxCoeff() + 2.0 * voxel;
  const double leaf_half_diagonal = 0.5 * std::sqrt(3.0) * root_edge / std::ldexp(1.0, params.depth);
  // A cell holds surface when |D(centre)| <= half diagonal; one voxel of slack absorbs the level
  // set's own error, so that no cell touched by the input surface is lost.
  const double slack = voxel;
  const DistanceField field(shape, 0.5 * root_edge, leaf_half_diagonal + 2.0 * slack);
  DistanceField::Probe probe(field);

  // Level by level: the children of every kept cell, kept when they hold surface or lie inside.
  std::vector<std::vector<Cell>> levels(static_cast<std::size_t>(params.depth) + 1);
  std::vector<double> depth_of_leaf;
  levels[0].push_back({box.center(), 0, true, 0});
  for (int level = 0; level < params.depth; ++level) {
    report(progress, "octree: level", static_cast<double>(level) / params.depth);
    const double child_edge = root_edge / std::ldexp(1.0, level + 1);
    const double child_half_diagonal = 0.5 * std::sqrt(3.0) * child_edge;
    auto& parents = levels[static_cast<std::size_t>(level)];
    auto& children = levels[static_cast<std::size_t>(level) + 1];
    for (uint32_t p = 0; p < parents.size(); ++p) {
      for (int octant = 0; octant < 8; ++octant) {
        const Vec3 offset((octant & 1) ? 0.25 : -0.25, (octant & 2) ? 0.25 : -0.25,
                          (octant & 4) ? 0.25 : -0.25);
        const Vec3 center = parents[p].center + 2.0 * child_edge * offset;
        const double d = probe.distance(center);
        const bool surface_cell = std::abs(d) <= child_half_diagonal + slack;
        if (d < 0.0 || surface_cell) {
          children.push_back({center, p, surface_cell, 0});
          ++parents[p].kept_children;
        }
      }
    }
  }

  // Drop inner cells left without leaves below them (bottom-up), keeping the order within a level.
  std::vector<std::vector<uint32_t>> new_index(levels.size());
  for (std::size_t level = levels.size(); level-- > 0;) {
    auto& cells = levels[level];
    std::vector<Cell> kept;
    new_index[level].assign(cells.size(), UINT32_MAX);
    for (uint32_t i = 0; i < cells.size(); ++i) {
      const bool is_leaf_level = level + 1 == levels.size();
      if (is_leaf_level || cells[i].kept_children > 0) {
        new_index[level][i] = static_cast<uint32_t>(kept.size());
        kept.push_back(cells[i]);
      } else if (level > 0) {
        --levels[level - 1][cells[i].parent].kept_children;
      }
    }
    cells = std::move(kept);
  }
  for (std::size_t level = 1; level < levels.size(); ++level) {
    for (Cell& c : levels[level]) c.parent = new_index[level - 1][c.parent];
  }
  if (levels.back().empty()) return {};

  // Flat layout, level by level; the children of a cell are contiguous because they were appended
  // together.
  SphereTree tree;
  tree.mode = TreeMode::Octree;
  tree.levels = params.depth + 1;
  std::vector<uint32_t> level_offset(levels.size(), 0);
  std::size_t total = 0;
  for (std::size_t level = 0; level < levels.size(); ++level) {
    level_offset[level] = static_cast<uint32_t>(total);
    total += levels[level].size();
  }
  tree.nodes.resize(total);
  for (std::size_t level = 0; level < levels.size(); ++level) {
    const double radius = 0.5 * std::sqrt(3.0) * root_edge / std::ldexp(1.0, static_cast<int>(level));
    const bool leaf_level = level + 1 == levels.size();
    for (uint32_t i = 0; i < levels[level].size(); ++i) {
      const Cell& cell = levels[level][i];
      SphereNode& node = tree.nodes[level_offset[level] + i];
      node.center = cell.center.cast<float>();
      node.radius = static_cast<float>(radius);
      if (leaf_level) {
        node.leaf = static_cast<uint32_t>(tree.leaf_nodes.size());
        node.flags = cell.surface ? kLeafOnExposedSurface : kLeafInterior;
        tree.leaf_nodes.push_back(level_offset[level] + i);
        tree.leaf_depth.push_back(static_cast<float>(-probe.distance(cell.center)));
      }
      if (level > 0) {
        SphereNode& parent = tree.nodes[level_offset[level - 1] + cell.parent];
        if (parent.count == 0) parent.first = level_offset[level] + i;
        ++parent.count;
      }
    }
  }
  report(progress, "octree: done", 1.0);
  return tree;
}

}  // namespace cariesim::detail
