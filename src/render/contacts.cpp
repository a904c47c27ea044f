// Sphere pairs -> contact regions -> constraint rows (DESIGN.md §4 steps 1-2).
//
// Each pair (tool leaf t, object leaf o) is linearised at the current graphic configuration: with
// lever a = c_t - p_g and normal n = (c_t - c_o)/|c_t - c_o|, a small motion (dp, dθ) changes the gap
// by n·(dp + dθ × a) = n·dp + (a × n)·dθ, so non-penetration is the row
//     n·dp + (a × n)·dθ >= -gap.
// On compliant tissue (finite stiffness k) the row is regularised with compliance 1/k: the tool may
// sink until the tissue's spring force λ = k·depth balances the coupling.
#include <algorithm>
#include <cmath>
#include <limits>

#include "render/internal.hpp"

namespace cariesim::detail {

Vec6 config_difference(const Pose& to, const Pose& from) {
  Vec6 d;
  d.head<3>() = to.p - from.p;
  d.tail<3>() = rotation_vector(to.q * from.q.conjugate());
  return d;
}

Pose apply_displacement(const Pose& g, const Vec6& d) {
  Pose out;
  out.p = g.p + d.head<3>();
  out.q = (quat_from_rotation_vector(d.tail<3>()) * g.q).normalized();
  return out;
}

void set_leaf_margins(const Model& m, StateImpl& s, double trans, double rot) {
  for (std::size_t i = 0; i < s.tool_leaves; ++i)
    s.leaf_margin[i] = trans + rot * s.leaf_reach[i] + m.settings.contact_margin;
}

bool collect_pairs(const Model& m, StateImpl& s, const Pose& g, ObjectMask mask) {
  s.placed.place(g, s.leaf_margin);
  s.contacts.clear();
  collide(s.placed, m.objects, mask, s.contacts, kStepPairsPerToolLeaf);
  const std::size_t found = s.contacts.size();
  s.pair_count = 0;
  if (found <= kMaxPairs) {
    for (std::size_t i = 0; i < found; ++i) {
      const Contact& c = s.contacts[i];
      s.pairs[s.pair_count++] = PairRef{c.object_node, c.tool_leaf, c.object, false};
    }
    return !s.contacts.overflow();
  }

  // More pairs than the rows can use: share the list fairly. Each (tool leaf, object) keeps its
  // nearest pairs, the same number for all, as many as fit; a crowd of deep pairs (a handle in soft
  // tissue) then cannot push out the few that hold the tip on a lesion's surface.
  std::span<uint32_t> order(s.contact_order.data(), found);
  for (std::size_t i = 0; i < found; ++i) order[i] = static_cast<uint32_t>(i);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const Contact& x = s.contacts[a];
    const Contact& y = s.contacts[b];
    if (x.tool_leaf != y.tool_leaf) return x.tool_leaf < y.tool_leaf;
    if (x.object != y.object) return x.object < y.object;
    return x.gap < y.gap;
  });
  std::array<int, kStepPairsPerToolLeaf + 1> per_rank{};
  for (std::size_t k = 0; k < found; ++k) {
    const bool same = k > 0 && s.contacts[order[k]].tool_leaf == s.contacts[order[k - 1]].tool_leaf &&
                      s.contacts[order[k]].object == s.contacts[order[k - 1]].object;
    s.contact_rank[k] =
        same ? static_cast<uint16_t>(std::min<int>(s.contact_rank[k - 1] + 1, kStepPairsPerToolLeaf))
             : uint16_t{0};
    ++per_rank[s.contact_rank[k]];
  }
  int keep_below = 0, total = 0;
  while (keep_below < static_cast<int>(kStepPairsPerToolLeaf) && total + per_rank[keep_below] <= kMaxPairs)
    total += per_rank[keep_below++];
  for (std::size_t k = 0; k < found; ++k) {
    if (s.contact_rank[k] >= keep_below) continue;
    const Contact& c = s.contacts[order[k]];
    s.pairs[s.pair_count++] = PairRef{c.object_node, c.tool_leaf, c.object, false};
  }
  return false;
}

PairGeometry pair_geometry(const Model& m, const StateImpl& s, const Pose& g, const PairRef& p) {
  const SphereTree& tree = m.objects[p.object].tree;
  const SphereNode& node = tree.nodes[p.object_node];
  const Vec3 c_t = leaf_world(s, g, p.tool_leaf);
  const Vec3 c_o = node.center.cast<double>();
  const double r_t = s.leaf_radius[p.tool_leaf];
  const double r_o = node.radius;
  PairGeometry out;
  out.lever = c_t - g.p;

  // Compliant tissue, with the tool over one of the leaf's tangent patches: depth below that patch's
  // plane, using the tangent that faces the tool. Every leaf of one flat patch then gives the same
  // depth and normal, however many overlap, and the depth stays right when the tool sinks deeper
  // than the leaf's centre.
  // A caries tree's walls (its interface with healthy tissue) are not a surface the tool can meet
  // (the healthy tree's walls there are): its leaves are measured against their exposed patches
  // only, and a leaf with nothing but wall patches is marked `wall` and ignored.
  const Vec3 d = c_t - c_o;
  if (!m.defaults.materials[node.material].rigid() && node.leaf < tree.leaf_tangents.size()) {
    const LeafTangents& t = tree.leaf_tangents[node.leaf];
    const bool lesion = m.objects[p.object].lesion >= 0;
    int best = -1;
    double best_h = -std::numeric_limits<double>::infinity();
    for (int k = 0; k < t.count; ++k) {
      if (lesion && ((t.wall_mask >> k) & 1u)) continue;
      const double h = d.dot(t.normal[k].cast<double>());
      if (h > best_h) best_h = h, best = k;
    }
    out.wall = lesion && t.count > 0 && best < 0;
    if (best >= 0) {
      const Vec3 n_s = t.normal[best].cast<double>();
      const double lateral = (d - best_h * n_s).norm();
      if (lateral <= r_o) {
        out.normal = n_s;
        out.gap = best_h - r_o - r_t;
        out.lateral = lateral;
        return out;
      }
    }
  }

  // Sphere against sphere.
  const double dist = d.norm();
  // Coincident centres: push along the tool's own axis, any finite direction will do.
  out.normal = dist > 1e-12 ? Vec3(d / dist) : Vec3(g.z_axis());
  out.gap = dist - r_t - r_o;
  return out;
}

void build_regions(const Model& m, StateImpl& s, const Pose& g) {
  // Geometry of every pair at g, then pairs ordered from the deepest.
  for (int i = 0; i < s.pair_count; ++i) {
    s.geometry[i] = pair_geometry(m, s, g, s.pairs[i]);
    s.order[i] = static_cast<int16_t>(i);
  }
  std::sort(s.order.begin(), s.order.begin() + s.pair_count,
            [&](int16_t a, int16_t b) { return s.geometry[a].gap < s.geometry[b].gap; });

  // Group into regions: same object, tool points within kRegionRadius. The deepest pair founds it.
  s.region_count = 0;
  for (int k = 0; k < s.pair_count; ++k) {
    const int i = s.order[k];
    const PairRef& p = s.pairs[i];
    const SphereNode& node = m.objects[p.object].tree.nodes[p.object_node];
    const Material& mat = m.defaults.materials[node.material];  // rigidity is the Model's
    s.pair_region[i] = -1;
    if (s.geometry[i].wall) continue;  // see pair_geometry
    const Vec3& local = s.leaf_local[p.tool_leaf];
    int r = 0;
    for (; r < s.region_count; ++r) {
      const Region& reg = s.regions[r];
      if (reg.object == p.object && (reg.tool_point_local - local).norm() < kRegionRadius) break;
    }
    if (r == s.region_count) {
      if (s.region_count == kMaxRegions) continue;
      Region& reg = s.regions[s.region_count++];
      reg.tool_point_local = local;
      reg.normal = s.geometry[i].normal;
      reg.gap = s.geometry[i].gap;
      reg.normal_force = 0.0;
      reg.object = p.object;
      reg.material = node.material;
      reg.tool_leaf = p.tool_leaf;
      reg.pair = static_cast<int16_t>(i);
      reg.compliant = !mat.rigid();
      reg.tip = local.norm() <= kTipRegion;
    }
    // The tip is in this region when any of its pairs is the tip's, not only the founding one.
    s.regions[r].tip = s.regions[r].tip || local.norm() <= kTipRegion;
    s.pair_region[i] = static_cast<int16_t>(r);
  }
}

namespace {

// The row group of a pair: its compliant region, or its rigid (tool leaf, object) slot.
StateImpl::RowGroup* row_group(StateImpl& s, const PairRef& p, const Region& reg, int region) {
  if (reg.compliant) {
    StateImpl::RowGroup& g = s.region_rows[region];
    if (g.stamp != s.row_stamp) g = StateImpl::RowGroup{s.row_stamp, p.object, 0, {}};
    return &g;
  }
  for (int slot = 0; slot < 2; ++slot) {
    StateImpl::RowGroup& g = s.leaf_rows[2 * p.tool_leaf + slot];
    if (g.stamp != s.row_stamp) {
      g = StateImpl::RowGroup{s.row_stamp, p.object, 0, {}};
      return &g;
    }
    if (g.object == p.object) return &g;
  }
  return nullptr;  // a third object for this tool leaf: its rows are not deduplicated
}

}  // namespace

int add_contact_rows(const Model& m, const Params& params, StateImpl& s, bool hold_only, uint32_t& flags) {
  int added = 0;
  ++s.row_stamp;
  const auto add_row = [&](int i, int r, StateImpl::RowGroup* group) {
    const PairGeometry& geo = s.geometry[i];
    const PairRef& p = s.pairs[i];
    QpRow row;
    row.a.head<3>() = geo.normal;
    row.a.tail<3>() = geo.lever.cross(geo.normal);
    row.b = -geo.gap;
    const Material& mat = params.materials[m.objects[p.object].tree.nodes[p.object_node].material];
    if (s.regions[r].compliant) {
      row.compliance = 1.0 / mat.stiffness;
    } else if (hold_only) {
      row.b = std::min(row.b, 0.0);
    }
    row.key = (uint64_t{p.object} << 48) ^ (uint64_t{p.tool_leaf} << 32) ^ p.object_node;
    if (!s.problem.add(row)) {
      flags |= kFlagQpRowsFull;
      return false;
    }
    const int index = s.problem.row_count - 1;
    s.meta[index] = RowMeta{RowKind::Contact, static_cast<int16_t>(r), -1, static_cast<int16_t>(i)};
    if (group != nullptr && group->count < 3) group->rows[group->count++] = static_cast<int16_t>(index);
    ++added;
    return true;
  };

  // Pass 1, pairs from the deepest: rigid pairs get rows, a few per (tool leaf, object) with distinct
  // normals (the rest are redundant). Compliant pairs elect, per region and distinct surface
  // direction, one pair of the deepest tool leaf: the leaf whose tangent point lies nearest that tool
  // leaf sideways, the best local estimate of the surface (so that many overlapping spheres do not
  // act as parallel springs).
  for (int k = 0; k < s.pair_count; ++k) {
    const int i = s.order[k];
    const int r = s.pair_region[i];
    if (r < 0) continue;
    const Region& reg = s.regions[r];
    const PairRef& p = s.pairs[i];
    StateImpl::RowGroup* group = row_group(s, p, reg, r);
    if (reg.compliant) {
      if (group == nullptr) continue;
      int similar = -1;
      for (int j = 0; j < group->count && similar < 0; ++j)
        if (s.geometry[group->rows[j]].normal.dot(s.geometry[i].normal) > kCompliantNormalCos) similar = j;
      if (similar >= 0) {
        // Pairs come deepest first, so the elector's tool leaf is the deepest; among that leaf's
        // pairs the patch nearest the tool sideways describes the surface best.
        const int elector = group->rows[similar];
        if (s.pairs[elector].tool_leaf == p.tool_leaf && s.geometry[i].lateral < s.geometry[elector].lateral)
          group->rows[similar] = static_cast<int16_t>(i);  // a pair, not a row
      } else if (group->count < kMaxRowsPerLeafObject) {
        group->rows[group->count++] = static_cast<int16_t>(i);
      }
      continue;
    }
    if (group != nullptr && !p.forced) {
      bool similar = false;
      for (int j = 0; j < group->count; ++j)
        similar = similar ||
                  s.geometry[s.meta[group->rows[j]].pair].normal.dot(s.geometry[i].normal) > kRigidNormalCos;
      if (similar || group->count >= kMaxRowsPerLeafObject) continue;
    }
    if (!add_row(i, r, group)) return added;
  }

  // Pass 2, compliant regions: a solid's penetration is the distance to its nearest surface, so of
  // the elected directions only those whose depth is within kCompliantDepthSlack of the shallowest
  // push (a tool sunk in soft caries that meets a firmer wall is pushed back by the wall, not thrown
  // up through the material above it). Directions not yet penetrated stay as constraints. Pairs
  // measured sphere against sphere (interior fillers, or a tool beside every leaf's patch) only
  // count when no surface patch lies over the tool: they catch a tool sunk deeper than the patches.
  for (int r = 0; r < s.region_count; ++r) {
    StateImpl::RowGroup& group = s.region_rows[r];
    if (!s.regions[r].compliant || group.stamp != s.row_stamp) continue;
    bool planar = false;
    for (int j = 0; j < group.count; ++j) planar = planar || std::isfinite(s.geometry[group.rows[j]].lateral);
    double shallowest = std::numeric_limits<double>::infinity();
    for (int j = 0; j < group.count; ++j) {
      const PairGeometry& geo = s.geometry[group.rows[j]];
      if (geo.gap < 0.0 && (!planar || std::isfinite(geo.lateral)))
        shallowest = std::min(shallowest, -geo.gap);
    }
    const int electors = group.count;
    const std::array<int16_t, 3> pairs = group.rows;
    group.count = 0;
    for (int j = 0; j < electors; ++j) {
      const PairGeometry& geo = s.geometry[pairs[j]];
      if (planar && !std::isfinite(geo.lateral)) continue;
      if (-geo.gap > shallowest + kCompliantDepthSlack) continue;
      if (!add_row(pairs[j], r, nullptr)) return added;
    }
  }
  return added;
}

void accumulate_region_forces(StateImpl& s) {
  for (int r = 0; r < s.region_count; ++r) s.regions[r].normal_force = 0.0;
  for (int row = 0; row < s.problem.row_count; ++row) {
    const RowMeta& meta = s.meta[row];
    if (meta.kind == RowKind::Contact && meta.region >= 0)
      s.regions[meta.region].normal_force += std::max(0.0, s.result.lambda[row]);
  }
}

double recheck_rigid(const Model& m, StateImpl& s, const Pose& g, ObjectMask mask, int& added) {
  added = 0;
  const ObjectMask rigid = mask & s.rigid_mask;
  s.placed.place(g, 0.0);
  const ClosestPair worst = closest(s.placed, m.objects, rigid, 0.0);
  if (!(worst.gap < -m.settings.rigid_tolerance)) return std::isfinite(worst.gap) ? worst.gap : 0.0;

  // Overlaps beyond the tolerance: bring every such pair into the list.
  std::fill(s.leaf_margin.begin(), s.leaf_margin.end(), 0.0);
  s.placed.place(g, s.leaf_margin);
  s.contacts.clear();
  collide(s.placed, m.objects, rigid, s.contacts, kStepPairsPerToolLeaf);
  for (std::size_t c = 0; c < s.contacts.size() && s.pair_count < kMaxPairs; ++c) {
    const Contact& con = s.contacts[c];
    if (!(con.gap < -m.settings.rigid_tolerance)) continue;
    bool known = false;
    for (int i = 0; i < s.pair_count && !known; ++i) {
      const PairRef& p = s.pairs[i];
      known = p.object_node == con.object_node && p.tool_leaf == con.tool_leaf && p.object == con.object;
    }
    if (known) continue;
    s.pairs[s.pair_count++] = PairRef{con.object_node, con.tool_leaf, con.object, true};
    ++added;
  }
  return worst.gap;
}

}  // namespace cariesim::detail
