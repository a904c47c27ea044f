#pragma once
// Stage 3, contact rows (contact_rows.cpp): the non-penetration rows of paper eq. 1, linearised, and
// the owner of the contact rows' key space (contact_key).

#include <array>
#include <cstdint>
#include <vector>

#include "render/pairs.hpp"
#include "render/regions.hpp"
#include "render/rows.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

inline constexpr int kMaxRowsPerGroup = 3;       ///< rows per rigid (tool leaf, object) or compliant region
inline constexpr double kRigidNormalCos = 0.97;  ///< rigid rows closer in direction are redundant
inline constexpr double kCompliantNormalCos = 0.9;  ///< compliant rows closer would add stiffness
/// mm: a compliant direction up to this much deeper than the shallowest pushes with the tissue's
/// stiffness; deeper, its stiffness fades linearly, to none at twice this (compliant_depth_fade).
inline constexpr double kCompliantDepthSlack = 0.05;
/// The share (0-1] of the tissue's stiffness a compliant direction `depth` (mm) deep pushes with when
/// the region's shallowest is `shallowest` (mm); 0 when it makes no row.
double compliant_depth_fade(double depth, double shallowest);

/// Key of a contact row (rows.hpp lists the key spaces).
inline constexpr uint64_t contact_key(const PairRef& p) {
  return (uint64_t{p.object} << 48) | (uint64_t{p.tool_leaf} << 32) | p.object_node;
}

/// Scratch of the contact row builder: the pairs already given rows (a rigid (tool leaf, object)) or
/// elected (a compliant region), stamped per build so that nothing is cleared.
struct ContactRowScratch {
  explicit ContactRowScratch(const ModelConstants& k);
  struct PairGroup {
    uint64_t stamp = 0;  ///< equals `stamp` when the group belongs to the current build
    uint16_t object = 0;
    uint8_t count = 0;
    std::array<int16_t, kMaxRowsPerGroup> pairs{};  ///< pair indices
  };
  std::array<PairGroup, kMaxRegions> region_groups{};  ///< compliant regions: elected pairs
  std::vector<PairGroup> leaf_groups;  ///< two per tool leaf (a leaf may touch two rigid objects)
  uint64_t stamp = 0;
};

/// Contact rows: a few rows with distinct normals per rigid (tool leaf, object); per compliant region
/// one row per distinct surface direction, of compliance 1/stiffness. `hold_only`: rigid rows never
/// demand moving out of an existing overlap (inside the tunnel). Returns the rows added.
int build_contact_rows(const Model& m, const Params& p, const PairSet& pairs, const RegionSet& regions,
                       bool hold_only, ContactRowScratch& scratch, RowSet& rows);

}  // namespace cariesim::detail
