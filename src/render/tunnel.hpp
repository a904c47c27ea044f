#pragma once
// The penetration state (tunnel.cpp; paper §3.3, Figs. 4-8): entry, the virtual tunnel's limits for
// one cycle, the tunnel row builder (owner of the tunnel rows' key space, tunnel_key) and one cycle
// inside the lesion.

#include <cstdint>

#include "render/rows.hpp"
#include "render/stages.hpp"

namespace cariesim::detail {

/// The virtual tunnel of the penetration state (paper §3.3.1, Fig. 5).
struct Tunnel {
  Vec3 entry = Vec3::Zero();       ///< mm, world, tip centre when insertion began
  Vec3 n = Vec3::UnitZ();          ///< insertion direction, frozen at entry (unit)
  Quat q_lock = Quat::Identity();  ///< tool orientation held by the tunnel
  double depth = 0.0;              ///< mm, tip-centre travel along n since entry
  double max_depth = 0.0;          ///< mm, travel at which the tip reaches the lesion's bottom
  double depth0 = 0.0;             ///< mm, how deep the tip's apex was below the surface at entry
  int16_t lesion = -1;
  int16_t object = -1;  ///< the lesion's caries tree, left out of collision while inside
  uint16_t material = 0;
};

/// The tip engaged on a lesion's surface before it breaks in (docs/penetration.md "Engagement"): once
/// the press along the tip axis (eqs. 3-4's |F_p|) exceeds kEngageShare of F_p* on caries, the sharp
/// tip catches where it is: it may still sink or rise along its axis n, but not slide sideways, so
/// pressing harder breaks in there instead of skating across the soft surface; the tool's
/// orientation is held as in the tunnel, so a shank resting on a neighbour cannot pivot off it.
struct Engagement {
  bool active = false;
  Vec3 point = Vec3::Zero();      ///< mm, world, tip centre when the tip caught
  Vec3 n = Vec3::UnitZ();         ///< the tip axis then (unit, into the tissue)
  Quat q = Quat::Identity();      ///< the tool's orientation then, held while caught (as eq. 7's lock)
  Vec3 last_hand = Vec3::Zero();  ///< mm, world, the hand's position in the last sliding cycle
};
/// The tip catches when the press along its axis exceeds kEngageShare of F_p*; it lets go when the
/// press falls below kReleaseShare of F_p* or the hand slides (N/N).
inline constexpr double kEngageShare = 0.02;
inline constexpr double kReleaseShare = 0.01;
/// A hand moving across the axis by more than kSlideMotion (mm per cycle) and more than kSlideSlope
/// times along it (tan 20 deg: a press wavers less) slides.
inline constexpr double kSlideMotion = 1e-4;
inline constexpr double kSlideSlope = 0.364;
inline constexpr double kReleaseSideways = 0.5;
/// The sliding state's engagement for this cycle (the tip's caries contact of the last cycle, the
/// press toward `haptic`): catches, holds or lets go. True when engaged.
bool update_engagement(const Params& p, StateImpl& s, const Pose& haptic);
/// The engaged tip's rows (the tunnel's lateral and rotation keys: never both in one problem): the
/// tip stays on the line through `e.point` along `e.n`, the orientation at `e.q`.
void build_engagement_rows(const Engagement& e, const Pose& g0, RowSet& rows);

/// The tunnel's limits for one cycle: the tip's travel along n stays in [lower, upper] (mm).
struct TunnelLimits {
  const Tunnel* tunnel = nullptr;
  double lower = 0.0;  ///< mm, shallowest travel allowed (the tissue's hold, eq. 9)
  double upper = 0.0;  ///< mm, deepest travel allowed (the bottom sphere, moved by eq. 5)
};

/// The tunnel's rows, which are also their keys' low bits.
enum class TunnelRow : uint64_t {
  Lateral0 = 0x00,
  Lateral1 = 0x01,
  Rotation0 = 0x10,
  Rotation1 = 0x11,
  Rotation2 = 0x12,
  Bottom = 0x20,
  Hold = 0x21,
};
/// Key of a tunnel row (rows.hpp lists the key spaces).
inline constexpr uint64_t tunnel_key(TunnelRow row) { return kTunnelKeys | static_cast<uint64_t>(row); }
/// Tunnel rows: two lateral equalities (the four side spheres), three rotation equalities (eq. 7's
/// lock), the bottom sphere and the tissue's hold.
void build_tunnel_rows(const TunnelLimits& limits, const Pose& g0, RowSet& rows);

/// Sliding -> penetration (paper §3.1 criteria, eqs. 3-4): the tip touched caries in the last cycle and
/// the insertion force along the tip axis exceeds F_p*. Opens the tunnel and returns true.
bool try_enter_penetration(const Model& m, const Params& p, StateImpl& s, const Pose& haptic);
/// The tunnel's limits for this cycle: depth growth (eq. 5), holding and extraction (eqs. 8-9); may
/// switch between inserting and extracting.
TunnelLimits tunnel_limits(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt);
/// One cycle inside the lesion: the tunnel rows with the additional contacts in one sub-step (Fig. 7);
/// at full extraction the state returns to sliding.
void penetration_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt,
                      StepTrace& trace);
/// The five tunnel spheres for display (Fig. 5).
void tunnel_spheres(const Model& m, const StateImpl& s, TunnelSpheres& out);

}  // namespace cariesim::detail
