// Stage 2, regions: the pairs of one scene object near one point of the tool form a contact region,
// the unit of compliance (one row per surface direction, however many spheres overlap) and of friction
// (one anchor per region). The parts of a cut object (its healthy tree and its caries trees, paper
// §2.2) are one surface: where the tool touches two of them at a lesion's border, their pairs share
// one region when both are compliant or both rigid, so that the tissue there is not a double spring
// (issue #10). The region's object and material are those of the part under the tool: the one whose
// tangent patch the founding tool leaf lies nearest sideways (the founder's when no patch covers it).
#include <algorithm>
#include <limits>

#include "render/stages.hpp"

namespace cariesim::detail {

void build_regions(const Model& m, const ModelConstants& k, const PairSet& pairs, RegionSet& out) {
  // Pairs ordered from the deepest. The keys carry their gaps, so that the sort reads no geometry
  // (issue #11: it was a tenth of a sweep's slowest steps); std::sort's moves follow its comparisons
  // alone, so pairs of equal gap come out in the order an index sort would give.
  out.pairs = pairs.count;
  for (int i = 0; i < pairs.count; ++i) out.keys[i] = {pairs.geometry[i].gap, static_cast<int16_t>(i)};
  std::sort(out.keys.begin(), out.keys.begin() + pairs.count,
            [](const RegionSet::GapKey& a, const RegionSet::GapKey& b) { return a.gap < b.gap; });
  for (int i = 0; i < pairs.count; ++i) out.order[i] = out.keys[i].pair;

  // Group into regions: same object, tool points within kRegionRadius. The deepest pair founds it.
  out.count = 0;
  for (int j = 0; j < pairs.count; ++j) {
    const int i = out.order[j];
    const PairRef& p = pairs.refs[i];
    const PairGeometry& geo = pairs.geometry[i];
    const SphereNode& node = m.objects[p.object].tree.nodes[p.object_node];
    const Material& mat = m.defaults.materials[node.material];  // rigidity is the Model's
    out.pair_region[i] = -1;
    if (geo.wall) continue;  // see measure_pair
    const Vec3& local = k.leaf_local[p.tool_leaf];
    const int16_t scene_object = m.objects[p.object].scene_object;
    const bool compliant = !mat.rigid();
    int r = 0;
    for (; r < out.count; ++r) {
      const Region& reg = out.regions[r];
      const bool same_surface = reg.object == p.object ||
                                (scene_object >= 0 && m.objects[reg.object].scene_object == scene_object &&
                                 reg.compliant == compliant);
      if (same_surface && (reg.tool_point_local - local).norm() < kRegionRadius) break;
    }
    if (r == out.count) {
      if (out.count == kMaxRegions) continue;
      Region& reg = out.regions[out.count++];
      reg.tool_point_local = local;
      reg.normal = geo.normal;
      reg.gap = geo.gap;
      reg.object = p.object;
      reg.material = node.material;
      reg.tool_leaf = p.tool_leaf;
      reg.pair = static_cast<int16_t>(i);
      reg.compliant = compliant;
      reg.tip = local.norm() <= kTipRegion;
      reg.lateral = geo.internal ? std::numeric_limits<double>::infinity() : geo.lateral;
    } else if (p.tool_leaf == out.regions[r].tool_leaf && p.object != out.regions[r].object &&
               !geo.internal && geo.lateral < out.regions[r].lateral) {
      // Another part of the same surface whose patch lies nearer under the founding tool leaf.
      out.regions[r].object = p.object;
      out.regions[r].material = node.material;
      out.regions[r].lateral = geo.lateral;
    }
    // The tip is in this region when any of its pairs is the tip's, not only the founding one.
    out.regions[r].tip = out.regions[r].tip || local.norm() <= kTipRegion;
    out.pair_region[i] = static_cast<int16_t>(r);
  }
}

}  // namespace cariesim::detail
