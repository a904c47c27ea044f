// Stage 2, regions: the pairs of one object near one point of the tool form a contact region, the
// unit of compliance (one row per surface direction, however many spheres overlap) and of friction
// (one anchor per region).
#include <algorithm>

#include "render/stages.hpp"

namespace cariesim::detail {

void build_regions(const Model& m, const ModelConstants& k, const PairSet& pairs, RegionSet& out) {
  // Pairs ordered from the deepest.
  out.pairs = pairs.count;
  for (int i = 0; i < pairs.count; ++i) out.order[i] = static_cast<int16_t>(i);
  std::sort(out.order.begin(), out.order.begin() + pairs.count,
            [&](int16_t a, int16_t b) { return pairs.geometry[a].gap < pairs.geometry[b].gap; });

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
    int r = 0;
    for (; r < out.count; ++r) {
      const Region& reg = out.regions[r];
      if (reg.object == p.object && (reg.tool_point_local - local).norm() < kRegionRadius) break;
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
      reg.compliant = !mat.rigid();
      reg.tip = local.norm() <= kTipRegion;
    }
    // The tip is in this region when any of its pairs is the tip's, not only the founding one.
    out.regions[r].tip = out.regions[r].tip || local.norm() <= kTipRegion;
    out.pair_region[i] = static_cast<int16_t>(r);
  }
}

}  // namespace cariesim::detail
