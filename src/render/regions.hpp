#pragma once
// Stage 2, regions (regions.cpp): the pairs of one scene object near one point of the tool form a
// contact region, the unit of compliance and of friction.

#include <array>
#include <cstdint>
#include <limits>

#include "render/pairs.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

inline constexpr double kTipRegion = 0.3;  ///< mm: tool leaves this close to the tip count as "the tip"

/// The contacts of one object near one point of the tool: the unit of compliance (one row per
/// direction on compliant tissue, so stiffness does not depend on how many spheres overlap) and of
/// friction (one stick constraint per region).
struct Region {
  Vec3 tool_point_local = Vec3::Zero();  ///< mm, tool frame: centre of the deepest tool leaf
  Vec3 normal = Vec3::UnitZ();           ///< unit, world, of the deepest pair
  double gap = 0.0;                      ///< mm, of the deepest pair
  uint16_t object = 0;
  uint16_t material = 0;
  uint16_t tool_leaf = 0;
  int16_t pair = -1;  ///< the deepest pair, which founded the region
  bool compliant = false;
  bool tip = false;  ///< one of its tool leaves lies within the tip region
  /// mm, sideways distance of the founding tool leaf from the patch of the part the region is
  /// attributed to (`object`, `material`); +infinity when measured sphere against sphere.
  double lateral = std::numeric_limits<double>::infinity();
};

/// The regions stage's output.
struct RegionSet {
  std::array<Region, kMaxRegions> regions{};
  int count = 0;
  std::array<int16_t, kMaxPairs> order{};  ///< the pairs, deepest first
  /// Scratch of the sort: each pair's gap (mm) beside its index, so that the sort reads no geometry.
  struct GapKey {
    double gap;
    int16_t pair;
  };
  std::array<GapKey, kMaxPairs> keys{};
  std::array<GapKey, kMaxPairs> bucketed{};          ///< scratch of the sort: the keys sorted by buckets
  std::array<uint16_t, kMaxPairs + 1> bucket_end{};  ///< scratch of the sort: where each bucket ends
  std::array<int16_t, kMaxPairs> pair_region{};      ///< region of each pair, -1 for none (a wall, or full)
  int pairs = 0;  ///< pairs the set was built from (forced pairs added later belong to no region yet)
};

/// Sorts the pairs by gap and groups them into regions: same object, tool points within
/// kRegionRadius of the deepest pair's, which founds the region.
void build_regions(const Model& m, const ModelConstants& k, const PairSet& pairs, RegionSet& out);

}  // namespace cariesim::detail
