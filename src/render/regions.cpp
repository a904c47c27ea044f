// Stage 2, regions: the pairs of one scene object near one point of the tool form a contact region,
// the unit of compliance (one row per surface direction, however many spheres overlap) and of friction
// (one anchor per region). The parts of a cut object (its healthy tree and its caries trees, paper
// §2.2) are one surface: where the tool touches two of them at a lesion's border, their pairs share
// one region when both are compliant or both rigid, so that the tissue there is not a double spring
// (docs/scene-format.md, "Lesions"). The region's object and material are those of the part under the tool:
// the one whose tangent patch the founding tool leaf lies nearest sideways (the founder's when no patch
// covers it).
#include "render/regions.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cariesim::detail {

namespace {

// From this many pairs on, the keys are sorted by buckets (below it std::sort is as fast).
constexpr int kBucketSortFrom = 32;

// Sorts keys[0..n) by gap into `sorted`, in the one order any sort gives when the gaps are distinct:
// spread over n buckets linear in the gap, then finished by insertion (the result is nearly sorted).
// Returns false when it cannot promise std::sort's order: two equal gaps (std::sort orders those its
// own way), or a gap that is not finite. Issue #11: std::sort's comparisons of unordered gaps
// mispredict, and on the sweep's slowest steps (70-260 pairs) it took 8 % of the step; this takes
// about 2.5 times less there.
bool bucket_sort(const RegionSet::GapKey* keys, int n, RegionSet::GapKey* sorted, uint16_t* bucket_end) {
  double lo = keys[0].gap, hi = keys[0].gap;  // mm
  for (int i = 1; i < n; ++i) {
    lo = std::min(lo, keys[i].gap);
    hi = std::max(hi, keys[i].gap);
  }
  const double scale = static_cast<double>(n - 1) / (hi - lo);  // buckets per mm
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo) || !std::isfinite(scale)) return false;
  const auto bucket = [&](double gap) { return std::min(static_cast<int>((gap - lo) * scale), n - 1); };
  std::fill(bucket_end, bucket_end + n + 1, uint16_t{0});
  for (int i = 0; i < n; ++i) ++bucket_end[bucket(keys[i].gap) + 1];
  for (int b = 0; b < n; ++b) bucket_end[b + 1] = static_cast<uint16_t>(bucket_end[b + 1] + bucket_end[b]);
  for (int i = 0; i < n; ++i) sorted[bucket_end[bucket(keys[i].gap)]++] = keys[i];
  for (int i = 1; i < n; ++i) {
    const RegionSet::GapKey moving = sorted[i];
    int j = i;
    for (; j > 0 && moving.gap < sorted[j - 1].gap; --j) sorted[j] = sorted[j - 1];
    sorted[j] = moving;
  }
  for (int i = 1; i < n; ++i)
    if (sorted[i].gap == sorted[i - 1].gap) return false;
  return true;
}

}  // namespace

void build_regions(const Model& m, const ModelConstants& k, const PairSet& pairs, RegionSet& out) {
  // Pairs ordered from the deepest. The keys carry their gaps, so that the sort reads no geometry
  // (it was a tenth of a sweep's slowest steps, docs/performance.md); std::sort's moves follow its
  // comparisons alone, so pairs of equal gap come out in the order an index sort would give. Many pairs of
  // distinct gaps are sorted by buckets, into the same order.
  out.pairs = pairs.count;
  for (int i = 0; i < pairs.count; ++i) out.keys[i] = {pairs.geometry[i].gap, static_cast<int16_t>(i)};
  const RegionSet::GapKey* sorted = out.bucketed.data();
  if (pairs.count < kBucketSortFrom ||
      !bucket_sort(out.keys.data(), pairs.count, out.bucketed.data(), out.bucket_end.data())) {
    std::sort(out.keys.begin(), out.keys.begin() + pairs.count,
              [](const RegionSet::GapKey& a, const RegionSet::GapKey& b) { return a.gap < b.gap; });
    sorted = out.keys.data();
  }
  for (int i = 0; i < pairs.count; ++i) out.order[i] = sorted[i].pair;

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
