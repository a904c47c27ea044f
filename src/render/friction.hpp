#pragma once
// Friction on caries in the sliding state (friction.cpp; paper §3.2, Figs. 10-11): the anchors stage
// before each solve's rows, the friction row builder (owner of the friction rows' key space,
// friction_key), the slip stage between the final solve of a sub-step and its re-solve, and the new
// anchors at the end of a sliding cycle.

#include <array>
#include <cstdint>

#include "render/regions.hpp"
#include "render/rows.hpp"
#include "render/solve.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

/// A sticking contact (paper §3.2, docs/design.md §4 step 4): the tool point is held at `anchor` in
/// the tangent plane while the tangential load stays inside the static cone.
struct FrictionAnchor {
  Vec3 point_local = Vec3::Zero();  ///< mm, tool frame
  Vec3 anchor = Vec3::Zero();       ///< mm, world
  uint16_t object = 0;
  int16_t region = -1;  ///< its region in the current solve (set by attach_anchors)
  bool active = false;
};
using Anchors = std::array<FrictionAnchor, kMaxAnchors>;

/// Anchors stage, before the rows of each solve: every active anchor finds its region (released when
/// the tool left it) and is laid into that region's tangent plane at g0.
void attach_anchors(const RegionSet& regions, const Pose& g0, Anchors& anchors);

/// Key of tangent row `tangent` (0, 1) of anchor slot `anchor` (rows.hpp lists the key spaces).
inline constexpr uint64_t friction_key(int anchor, int tangent) {
  return kFrictionKeys | static_cast<uint64_t>(2 * anchor + tangent);
}
/// Friction rows: two tangent equality rows per attached anchor, t_j·(dp + dθ × a) = t_j·(anchor - x).
void build_friction_rows(const Anchors& anchors, const RegionSet& regions, const Pose& g0, RowSet& rows);

/// What the friction cone decided for each anchor after a solve.
struct SlipPlan {
  enum class Action : uint8_t { Keep, Release, Slip };
  std::array<Action, kMaxAnchors> action{};
  std::array<Vec3, kMaxAnchors> anchor{};  ///< mm, world: where a slipping anchor moves
  int changed = 0;                         ///< anchors released or moved (the rows must be solved again)
  int slipped = 0;                         ///< anchors moved (saw-tooth events)
};
/// The Coulomb cone after a solve at g0 (paper §3.2, Figs. 10-11): an anchor whose tangential load
/// left the static cone slips, its anchor moved so that the load falls onto the dynamic cone; an
/// anchor without normal load releases; the others stick. `G` is the coupling of the solve.
void decide_slips(const Params& p, const Anchors& anchors, const RegionSet& regions, const RowSet& rows,
                  const Solution& solution, const Pose& g0, const Mat6& G, SlipPlan& plan);
/// Moves and releases the anchors as planned.
void apply_slips(const SlipPlan& plan, Anchors& anchors);
/// Anchors for frictional regions under load that have none, at their tool point at g.
void create_anchors(const Params& p, const RegionSet& regions, const Solution& solution, const Pose& g,
                    Anchors& anchors);
/// Drops every anchor.
void release_anchors(Anchors& anchors);

}  // namespace cariesim::detail
