// Contact rows: the non-penetration constraint of paper eq. 1, linearised (docs/design.md §4 step 2).
//
// Each pair (tool leaf t, object leaf o) is linearised at the rows' configuration: with lever
// a = c_t - p_g and normal n (measure_pair), a small motion (dp, dθ) changes the gap by
// n·(dp + dθ × a) = n·dp + (a × n)·dθ, so non-penetration is the row
//     n·dp + (a × n)·dθ >= -gap.
// On compliant tissue (finite stiffness k) the row is regularised with compliance 1/k: the tool may
// sink until the tissue's spring force λ = k·depth balances the coupling.
// This builder owns the contact rows' key space (contact_key).
#include "render/contact_rows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cariesim::detail {

namespace {

using PairGroup = ContactRowScratch::PairGroup;

// The group of a pair: its compliant region, or its rigid (tool leaf, object) slot.
PairGroup* group_of(ContactRowScratch& sc, const PairRef& p, const Region& reg, int region) {
  if (reg.compliant) {
    PairGroup& g = sc.region_groups[region];
    if (g.stamp != sc.stamp) g = PairGroup{sc.stamp, p.object, 0, {}};
    return &g;
  }
  for (int slot = 0; slot < 2; ++slot) {
    PairGroup& g = sc.leaf_groups[2 * p.tool_leaf + slot];
    if (g.stamp != sc.stamp) {
      g = PairGroup{sc.stamp, p.object, 0, {}};
      return &g;
    }
    if (g.object == p.object) return &g;
  }
  return nullptr;  // a third object for this tool leaf: its rows are not deduplicated
}

// A healthy leaf's patch on a lesion's wall is the surface of its part, not of the tooth: inside
// tissue as firm as the part's own, the tool meets no wall there. So a pair measured against such a
// patch makes no row when the lesion behind the wall (of those the part hosts, the one whose boundary
// passes nearest the patch's tangent point) is at least as stiff as the part. The wall stays where the
// caries is softer, where a tip sunk in it catches (paper §4.2.1, Fig. 12).
bool internal_between_equals(const Model& m, const Params& params, const PairSet& pairs, int i) {
  const PairGeometry& geo = pairs.geometry[i];
  if (!geo.internal) return false;
  const PairRef& p = pairs.refs[i];
  const SphereNode& node = m.objects[p.object].tree.nodes[p.object_node];
  const Vec3 tangent_point = node.center.cast<double>() + double(node.radius) * geo.normal;
  int behind = -1;
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < m.lesions.size(); ++k) {
    if (m.lesions[k].host != static_cast<int>(p.object)) continue;
    const double d = std::abs(m.lesions[k].shape.distance(tangent_point));
    if (d < nearest) nearest = d, behind = static_cast<int>(k);
  }
  return behind >= 0 && params.materials[m.lesions[static_cast<std::size_t>(behind)].material].stiffness >=
                            params.materials[node.material].stiffness;
}

}  // namespace

double compliant_depth_fade(double depth, double shallowest) {
  // A fade below 1e-3 would push with less than 0.1 % of the tissue's stiffness: no row.
  const double fade = 1.0 - std::max(0.0, depth - shallowest - kCompliantDepthSlack) / kCompliantDepthSlack;
  return fade >= 1e-3 ? fade : 0.0;
}

ContactRowScratch::ContactRowScratch(const ModelConstants& k) : leaf_groups(2 * k.tool_leaves) {}

int build_contact_rows(const Model& m, const Params& params, const PairSet& pairs, const RegionSet& regions,
                       bool hold_only, ContactRowScratch& sc, RowSet& rows) {
  int added = 0;
  ++sc.stamp;
  // One row per pair; a rigid group records the pairs that got one. A compliant row pushes with the
  // share `fade` of its tissue's stiffness.
  const auto add_row = [&](int i, int r, PairGroup* group, double fade = 1.0) {
    const PairGeometry& geo = pairs.geometry[i];
    const PairRef& p = pairs.refs[i];
    QpRow row;
    row.a.head<3>() = geo.normal;
    row.a.tail<3>() = geo.lever.cross(geo.normal);
    row.b = -geo.gap;
    const Material& mat = params.materials[m.objects[p.object].tree.nodes[p.object_node].material];
    if (regions.regions[r].compliant) {
      row.compliance = 1.0 / (mat.stiffness * fade);
    } else if (hold_only) {
      row.b = std::min(row.b, 0.0);
    }
    row.key = contact_key(p);
    if (!rows.add(row, RowMeta{RowKind::Contact, static_cast<int16_t>(r), -1, static_cast<int16_t>(i)}))
      return false;
    ++rows.contacts;
    if (group != nullptr && group->count < kMaxRowsPerGroup)
      group->pairs[group->count++] = static_cast<int16_t>(i);
    ++added;
    return true;
  };

  // Pass 1, pairs from the deepest: rigid pairs get rows, a few per (tool leaf, object) with distinct
  // normals (the rest are redundant), and every forced or carried one. Compliant pairs elect, per
  // region and distinct surface direction, one pair of the deepest tool leaf: the leaf whose tangent
  // point lies nearest that tool leaf sideways, the best local estimate of the surface (so that many
  // overlapping spheres do not act as parallel springs).
  for (int j = 0; j < regions.pairs; ++j) {
    const int i = regions.order[j];
    const int r = regions.pair_region[i];
    if (r < 0) continue;
    const Region& reg = regions.regions[r];
    const PairRef& p = pairs.refs[i];
    const PairGeometry& geo = pairs.geometry[i];
    PairGroup* group = group_of(sc, p, reg, r);
    if (reg.compliant) {
      if (group == nullptr || internal_between_equals(m, params, pairs, i)) continue;
      int similar = -1;
      for (int e = 0; e < group->count && similar < 0; ++e)
        if (pairs.geometry[group->pairs[e]].normal.dot(geo.normal) > kCompliantNormalCos) similar = e;
      if (similar >= 0) {
        // Pairs come deepest first, so the elector's tool leaf is the deepest; among that leaf's
        // pairs the patch nearest the tool sideways describes the surface best. Between two tool
        // leaves, though, the one whose pair bore load at the last solve (carried) keeps the
        // direction's vote: two tip leaves about as deep took turns at being the deepest, and with
        // them the patch elected and the solution (a five-step cycle of 0.01 mm on the oral
        // fissure; docs/performance.md). Within one leaf the vote stays with the nearest patch (the Fig. 12
        // hook needs it).
        const PairRef& elector = pairs.refs[group->pairs[similar]];
        const bool replace = elector.tool_leaf != p.tool_leaf
                                 ? p.carried && !elector.carried
                                 : geo.lateral < pairs.geometry[group->pairs[similar]].lateral;
        if (replace) group->pairs[similar] = static_cast<int16_t>(i);
      } else if (group->count < kMaxRowsPerGroup) {
        group->pairs[group->count++] = static_cast<int16_t>(i);
      }
      continue;
    }
    if (group != nullptr && !p.forced && !p.carried) {  // a carried rigid pair keeps its row (CarriedPairs)
      bool similar = false;
      for (int e = 0; e < group->count; ++e)
        similar = similar || pairs.geometry[group->pairs[e]].normal.dot(geo.normal) > kRigidNormalCos;
      if (similar || group->count >= kMaxRowsPerGroup) continue;
    }
    if (!add_row(i, r, group)) return added;
  }

  // Pass 2, compliant regions: a solid's penetration is the distance to its nearest surface, so of
  // the elected directions only those whose depth is within kCompliantDepthSlack of the shallowest
  // push with the tissue's stiffness (a tool sunk in soft caries that meets a firmer wall is pushed
  // back by the wall, not thrown up through the material above it). A deeper one's stiffness fades
  // out over the next kCompliantDepthSlack (compliant_depth_fade): an on/off rule let the solution
  // flip across it, and 12 % of the oral fissure's steps turned back. Directions not yet
  // penetrated stay as constraints. Pairs measured sphere against sphere (interior fillers, or a tool
  // beside every leaf's patch) only count when no surface patch lies over the tool: they catch a tool
  // sunk deeper than the patches.
  for (int r = 0; r < regions.count; ++r) {
    const PairGroup& group = sc.region_groups[r];
    if (!regions.regions[r].compliant || group.stamp != sc.stamp) continue;
    bool planar = false;
    for (int e = 0; e < group.count; ++e)
      planar = planar || std::isfinite(pairs.geometry[group.pairs[e]].lateral);
    double shallowest = std::numeric_limits<double>::infinity();
    for (int e = 0; e < group.count; ++e) {
      const PairGeometry& geo = pairs.geometry[group.pairs[e]];
      if (geo.gap < 0.0 && (!planar || std::isfinite(geo.lateral)))
        shallowest = std::min(shallowest, -geo.gap);
    }
    for (int e = 0; e < group.count; ++e) {
      const PairGeometry& geo = pairs.geometry[group.pairs[e]];
      if (planar && !std::isfinite(geo.lateral)) continue;
      const double fade = compliant_depth_fade(-geo.gap, shallowest);
      if (fade > 0.0 && !add_row(group.pairs[e], r, nullptr, fade)) return added;
    }
  }

  // Pass 3, hysteresis (CarriedPairs): a compliant pair measured on a surface patch that bore load
  // at the last solve keeps a row while it overlaps, unless its region already has a row of a
  // similar direction or the tool has sunk past it (pass 2's depth rule, which fades it).
  const int first_row = rows.problem.row_count - added;
  for (int i = 0; i < regions.pairs; ++i) {
    const PairGeometry& geo = pairs.geometry[i];
    const int r = regions.pair_region[i];
    if (!pairs.refs[i].carried || r < 0 || !regions.regions[r].compliant || !(geo.gap < 0.0)) continue;
    if (!std::isfinite(geo.lateral) || geo.internal) continue;  // a surface patch's direction only
    bool covered = false;
    double shallowest = std::numeric_limits<double>::infinity();
    for (int row = first_row; row < rows.problem.row_count && !covered; ++row) {
      const RowMeta& meta = rows.meta[row];
      if (meta.kind != RowKind::Contact || meta.region != r) continue;
      covered = pairs.geometry[meta.pair].normal.dot(geo.normal) > kCompliantNormalCos;
      shallowest = std::min(shallowest, std::max(0.0, -pairs.geometry[meta.pair].gap));
    }
    // Pass 2's depth rule: a direction the tool sinks past lets go, gradually.
    const double fade = compliant_depth_fade(-geo.gap, shallowest);
    if (!covered && fade > 0.0 && !add_row(i, r, nullptr, fade)) return added;
  }
  return added;
}

}  // namespace cariesim::detail
