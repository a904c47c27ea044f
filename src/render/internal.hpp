#pragma once
// Stages of the haptic step shared by its source files (step.cpp orchestrates them):
//   contacts.cpp  sphere pairs -> contact regions -> constraint rows (DESIGN.md §4 steps 1-2)
//   substep.cpp   one bounded optimisation with collision re-checks (§4 step 3, paper eq. 1)
//   friction.cpp  stick/slip anchors and the friction cone (§4 step 4, paper §3.2)
//   tunnel.cpp    the penetration state: virtual tunnel, eqs. 3-9 (§4 step 5, paper §3.3)

#include "cariesim/render/step.hpp"
#include "render/state_impl.hpp"

namespace cariesim::detail {

inline constexpr double kTipRegion = 0.3;        ///< mm: tool leaves this close to the tip count as "the tip"
inline constexpr double kRegionRadius = 1.0;     ///< mm: tool leaves this close share a contact region
inline constexpr int kMaxRowsPerLeafObject = 3;  ///< rows per rigid (tool leaf, object) or compliant region
inline constexpr double kRigidNormalCos = 0.97;  ///< rigid rows closer in direction than this are redundant
inline constexpr double kCompliantNormalCos = 0.9;  ///< compliant rows closer than this would add stiffness
inline constexpr double kCompliantDepthSlack =
    0.05;  ///< mm: compliant directions this much deeper than the shallowest do not push

/// 6-D difference (translation mm, rotation vector rad) that moves `from` onto `to`.
Vec6 config_difference(const Pose& to, const Pose& from);
/// `g` moved by a 6-D displacement (rotation about the tool-frame origin, world axes).
Pose apply_displacement(const Pose& g, const Vec6& d);
/// Tool leaf centre in the world at configuration g.
inline Vec3 leaf_world(const StateImpl& s, const Pose& g, int leaf) {
  return g.transform(s.leaf_local[leaf]);
}

// contacts.cpp
/// Sets every tool leaf's margin to the largest distance it can move under a displacement bounded by
/// `trans` (mm) and `rot` (rad), plus the contact margin.
void set_leaf_margins(const Model& m, StateImpl& s, double trans, double rot);
/// Collects the pairs within the leaf margins at g (replaces the pair list). Returns false on overflow.
bool collect_pairs(const Model& m, StateImpl& s, const Pose& g, ObjectMask mask);
/// Geometry of one pair at configuration g.
PairGeometry pair_geometry(const Model& m, const StateImpl& s, const Pose& g, const PairRef& p);
/// Recomputes the geometry of every pair at g, sorts them by gap and groups them into regions.
void build_regions(const Model& m, StateImpl& s, const Pose& g);
/// Appends contact rows for the regions (one per compliant region, distinct normals for rigid ones).
/// `hold_only`: rigid rows never demand moving out of an existing overlap (used inside the tunnel).
/// Returns the number of rows added.
int add_contact_rows(const Model& m, const Params& p, StateImpl& s, bool hold_only, uint32_t& flags);
/// Sums each region's contact multipliers into Region::normal_force.
void accumulate_region_forces(StateImpl& s);
/// Smallest gap (mm) between the tool at g and the rigid objects in `mask`; adds every pair
/// overlapping by more than the tolerance that is not yet in the list. Sets `added`.
double recheck_rigid(const Model& m, StateImpl& s, const Pose& g, ObjectMask mask, int& added);

// friction.cpp
/// Appends two tangent (stick) rows per active anchor whose region still exists; releases the others.
void add_friction_rows(StateImpl& s, const Pose& g, uint32_t& flags);
/// Friction cone check after a solve: anchors whose tangential load left the static cone slip to
/// the dynamic cone (counted in `slipped`); anchors without normal load are released. Returns how many
/// anchors changed (their rows must be solved again). `g` is the configuration the rows were built at.
int slip_anchors(const Params& p, StateImpl& s, const Pose& g, const Mat6& G, int& slipped);
/// Creates anchors for frictional regions under load that have none, at their position at g.
void create_anchors(const Params& p, StateImpl& s, const Pose& g);
/// Drops every anchor.
void release_anchors(StateImpl& s);

// substep.cpp
/// Extra rows a caller adds to every solve of a sub-step (the tunnel's).
struct ExtraRows {
  virtual ~ExtraRows() = default;
  virtual void add(const Pose& g0, QpProblem& problem, std::array<RowMeta, kQpMaxRows>& meta) const = 0;
};
struct SubstepRequest {
  Vec6 target = Vec6::Zero();  ///< 6-D displacement toward which the graphic tool is pulled
  Mat6 G = Mat6::Identity();   ///< weights of the distance (N/mm, N·mm/rad)
  double trans_bound = 0.0;    ///< mm, largest tool-origin motion of this sub-step (trust region)
  double rot_bound = 0.0;      ///< rad, largest rotation of this sub-step
  ObjectMask mask = kAllObjects;
  bool friction = true;    ///< add stick rows and check the cone
  bool hold_only = false;  ///< see add_contact_rows
  const ExtraRows* extra = nullptr;
};
/// Solves one sub-step from g0 (paper eq. 1 linearised: DESIGN.md §4 steps 1-4): the graphic tool is
/// pulled toward the full target but moves at most by the bounds (the solution is shortened onto
/// them; every pair within reach of that motion is in the rows). Sets `reached` when the solution
/// was within the bounds (the last sub-step of a cycle; the friction cone is checked only then).
/// Never leaves the tool overlapping rigid tissue by more than the tolerance when g0 did not:
/// re-checks collision at the solution, re-solves with new pairs, backtracks if needed.
Pose solve_substep(const Model& m, const Params& p, StateImpl& s, const Pose& g0, const SubstepRequest& req,
                   StepOutput& out, bool& reached);

// tunnel.cpp
/// Sliding -> penetration (paper §3.1 criteria, eqs. 3-4): the tip touched caries in the last step and
/// the insertion force along the tip axis exceeds F_p*. Opens the tunnel and returns true.
bool try_enter_penetration(const Model& m, const Params& p, StateImpl& s, const Pose& haptic);
/// One cycle inside the lesion: depth growth (eq. 5), holding and extraction (eqs. 8-9), the tunnel
/// rows with the additional contacts in one optimisation (Fig. 7).
void penetration_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt,
                      StepOutput& out);
/// The five tunnel spheres for display (Fig. 5).
void tunnel_spheres(const Model& m, const StateImpl& s, TunnelSpheres& out);

}  // namespace cariesim::detail
