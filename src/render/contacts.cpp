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
    s.leaf_margin[i] = trans + rot * s.leaf_reach[i] + m.params.contact_margin;
}

bool collect_pairs(const Model& m, StateImpl& s, const Pose& g, ObjectMask mask) {
  s.placed.place(g, s.leaf_margin);
  s.contacts.clear();
  collide(s.placed, m.objects, mask, s.contacts);
  const std::size_t n = std::min<std::size_t>(s.contacts.size(), kMaxPairs);
  for (std::size_t i = 0; i < n; ++i) {
    const Contact& c = s.contacts[i];
    s.pairs[i] = PairRef{c.object_node, c.tool_leaf, c.object, false};
  }
  s.pair_count = static_cast<int>(n);
  return !s.contacts.overflow() && s.contacts.size() <= kMaxPairs;
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

  // Compliant tissue, with the tool above the leaf's patch of surface: depth below that patch's
  // plane. Every leaf of one flat patch then gives the same depth and normal, however many overlap,
  // and the depth stays right when the tool sinks deeper than the leaf's centre.
  const Vec3 d = c_t - c_o;
  if (!m.materials[node.material].rigid() && node.leaf < tree.leaf_normal.size()) {
    const Vec3 n_s = tree.leaf_normal[node.leaf].cast<double>();
    const double h = d.dot(n_s);
    if (n_s.squaredNorm() > 0.5 && (d - h * n_s).norm() <= r_o) {
      out.normal = n_s;
      out.gap = h - r_o - r_t;
      return out;
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
    const Material& mat = m.materials[node.material];
    s.pair_region[i] = -1;
    // A caries tree's internal walls (its interface with healthy tissue) are not a surface the tool
    // can meet: the healthy tree's walls there are.
    if (m.objects[p.object].lesion >= 0 && (node.flags & kLeafOnLesionWall)) continue;
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

int add_contact_rows(const Model& m, StateImpl& s, bool hold_only, uint32_t& flags) {
  int added = 0;
  ++s.row_stamp;
  for (int k = 0; k < s.pair_count; ++k) {
    const int i = s.order[k];
    const int r = s.pair_region[i];
    if (r < 0) continue;
    const Region& reg = s.regions[r];
    const PairGeometry& geo = s.geometry[i];
    const PairRef& p = s.pairs[i];

    // Compliant tissue: per region, only the deepest pair of each distinct surface direction, so that
    // many overlapping spheres do not act as parallel springs. Rigid tissue: a few rows per
    // (tool leaf, object) with distinct normals; the rest are redundant.
    StateImpl::RowGroup* group = row_group(s, p, reg, r);
    if (group != nullptr && !p.forced) {
      const double cos_similar = reg.compliant ? kCompliantNormalCos : kRigidNormalCos;
      bool similar = false;
      for (int j = 0; j < group->count; ++j)
        similar = similar || s.geometry[s.meta[group->rows[j]].pair].normal.dot(geo.normal) > cos_similar;
      if (similar || group->count >= kMaxRowsPerLeafObject) continue;
    }

    QpRow row;
    row.a.head<3>() = geo.normal;
    row.a.tail<3>() = geo.lever.cross(geo.normal);
    row.b = -geo.gap;
    const Material& mat = m.materials[m.objects[p.object].tree.nodes[p.object_node].material];
    if (reg.compliant) {
      row.compliance = 1.0 / mat.stiffness;
    } else if (hold_only) {
      row.b = std::min(row.b, 0.0);
    }
    row.key = (uint64_t{p.object} << 48) ^ (uint64_t{p.tool_leaf} << 32) ^ p.object_node;
    if (!s.problem.add(row)) {
      flags |= kFlagQpRowsFull;
      break;
    }
    const int index = s.problem.row_count - 1;
    s.meta[index] = RowMeta{RowKind::Contact, static_cast<int16_t>(r), -1, static_cast<int16_t>(i)};
    if (group != nullptr && group->count < 3) group->rows[group->count++] = static_cast<int16_t>(index);
    ++added;
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
  if (!(worst.gap < -m.params.rigid_tolerance)) return std::isfinite(worst.gap) ? worst.gap : 0.0;

  // Overlaps beyond the tolerance: bring every such pair into the list.
  std::fill(s.leaf_margin.begin(), s.leaf_margin.end(), 0.0);
  s.placed.place(g, s.leaf_margin);
  s.contacts.clear();
  collide(s.placed, m.objects, rigid, s.contacts);
  for (std::size_t c = 0; c < s.contacts.size() && s.pair_count < kMaxPairs; ++c) {
    const Contact& con = s.contacts[c];
    if (!(con.gap < -m.params.rigid_tolerance)) continue;
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
