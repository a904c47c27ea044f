// The penetration state (paper §3.3, Figs. 4-8; docs/design.md §1 "Penetration state").
//
// Entry (§3.1, eqs. 3-4): the tip touched carious tissue in the last cycle and the insertion force
// along the tip axis, |F_p| = |(F_c·n)| with F_c = k_e (p_h^t - p_g^{t-1}), exceeds F_p*.
// The virtual tunnel (Fig. 5) freezes n and the tool's orientation at entry. Its five spheres — one on
// the axis below the tip, four around the head — become rows of the same optimisation as every other
// contact of the tool (Fig. 7): the four side spheres hold the tip on the axis (two lateral equality
// rows), the tunnel holds the orientation (three rotation rows: eq. 7's lock), the bottom sphere is an
// inequality that moves down as the lesion is opened, and the tissue holds the tip where it is (a
// second inequality) until the pull exceeds F_e* (eq. 9). Additional contacts of the whole tool with
// every other object are the usual contact rows.
// Depth growth, our reading of eq. 5 (docs/penetration.md): F_p* is the breakthrough threshold; once
// inside, the decayed tissue ahead of the tip resists with R(d) = k_c(d)·crush_length at apex depth d,
// and the tip advances while |F_p| > R(d), each cycle to where |F_p| = R(d) (quasi-static, so the
// servo rate does not matter). The felt axial force while inserting is therefore k_c(d)·crush_length
// (times k_p/k_e, eq. 6): it follows a layered or graded k_c (Fig. 6) and tells mild from severe
// caries at any hand speed. Eq. 5's own increment, |F_p|/k_c per 1 ms cycle (scaled by Δt / 1 ms),
// bounds the advance per cycle, and so does max_give_speed: a resistance below F_p* (a breakthrough)
// plays over several cycles instead of as one knock. Extraction mirrors the paper (eqs. 8-9): the
// probe stays until |F_e| > F_e*, then slides out along the shortening tunnel; at depth 0 the state
// returns to sliding and the force drops.
// Engagement (docs/penetration.md "Engagement"): in the sliding state a tip pressed on caries along
// its axis catches: it is held on its axis line and in its orientation (the tunnel's lateral and
// rotation rows) until eq. 4 opens the tunnel there, so it neither skates across soft caries nor
// slides or pivots off a neighbour that holds the shank.
// The tunnel row builder owns the tunnel rows' key space (tunnel_key).
#include "render/tunnel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cariesim/render/step.hpp"
#include "render/state_impl.hpp"
#include "render/substep.hpp"

namespace cariesim::detail {

namespace {

constexpr double kExitDepth = 1e-6;    // mm: at this depth the probe is out
constexpr double kBottomRadius = 0.1;  // mm: display radius of the tunnel spheres
constexpr double kSurfaceReach = 3.0;  // mm: deepest the apex may have sunk before it breaks in

// Distance along n from p at which the ray leaves the lesion volume (sphere tracing its SDF).
double lesion_exit(const LesionShape& shape, const Vec3& p, const Vec3& n) {
  double t = 0.0;
  double d = shape.distance(p);
  if (!(d < 0.0)) return 0.0;
  double t_inside = 0.0;
  for (int i = 0; i < 200 && t < 100.0; ++i) {
    d = shape.distance(p + t * n);
    if (d >= -1e-5) break;
    t_inside = t;
    t += std::max(-d, 1e-3);
  }
  // Refine by bisection between the last inside point and the first outside one.
  double lo = t_inside, hi = t;
  for (int i = 0; i < 30 && d > 0.0; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (shape.distance(p + mid * n) < 0.0)
      lo = mid;
    else
      hi = mid;
  }
  return d > 0.0 ? lo : t;
}

// How deep `apex` lies below the lesion's surface along the tunnel axis n (mm): the distance back
// along -n to where the ray leaves the caries tree (the lesion's part of the tooth, from the tooth's
// surface down). Sphere tracing from `reach` mm outside toward the apex: outside a union of spheres
// the smallest leaf gap is the exact distance to it, so each step lands on or before the surface.
// NaN when the query ran out of work budget; 0 when the apex is not inside the caries.
double surface_depth(const CollisionObject& caries, const Vec3& apex, const Vec3& n, double reach,
                     WorkBudget* budget) {
  constexpr double kHit = 1e-4;  // mm
  const Vec3 start = apex - n * reach;
  double t = 0.0;
  for (int i = 0; i < 64 && t < reach; ++i) {
    const double gap = sphere_closest(start + n * t, 0.0, caries, reach - t + kHit, budget);
    if (gap == -std::numeric_limits<double>::infinity()) return std::nan("");
    if (!std::isfinite(gap)) return 0.0;  // no caries before the apex
    if (gap < kHit) return std::max(reach - t, 0.0);
    t += gap;
  }
  return 0.0;
}

// The tip held on the line through `point` along `n` (the tunnel's four side spheres, Fig. 5) and the
// tool's orientation held at `q_lock` (eq. 7's constraint): two lateral rows and three rotation rows.
void add_axis_lock_rows(const Vec3& point, const Vec3& n, const Quat& q_lock, const Pose& g0, RowSet& rows) {
  const Vec3 axis_point = point + n * (g0.p - point).dot(n);
  Vec3 side[2];
  tangent_basis(n, side[0], side[1]);
  for (int j = 0; j < 2; ++j) {
    QpRow row;
    row.a.head<3>() = side[j];
    row.b = side[j].dot(axis_point - g0.p);
    row.equality = true;
    row.key = tunnel_key(j == 0 ? TunnelRow::Lateral0 : TunnelRow::Lateral1);
    rows.add(row, RowMeta{RowKind::TunnelLateral, -1, -1, -1});
  }
  const Vec3 back = rotation_vector(q_lock * g0.q.conjugate());
  constexpr TunnelRow kRotation[3] = {TunnelRow::Rotation0, TunnelRow::Rotation1, TunnelRow::Rotation2};
  for (int j = 0; j < 3; ++j) {
    QpRow row;
    row.a[3 + j] = 1.0;
    row.b = back[j];
    row.equality = true;
    row.key = tunnel_key(kRotation[j]);
    rows.add(row, RowMeta{RowKind::TunnelRotation, -1, -1, -1});
  }
}

}  // namespace

void build_tunnel_rows(const TunnelLimits& limits, const Pose& g0, RowSet& rows) {
  const Tunnel& t = *limits.tunnel;
  const double depth = (g0.p - t.entry).dot(t.n);
  const auto add = [&](QpRow row, RowKind kind, TunnelRow which) {
    row.key = tunnel_key(which);
    rows.add(row, RowMeta{kind, -1, -1, -1});
  };
  // The four side spheres keep the tip on the axis; the orientation is held (eq. 7's constraint).
  add_axis_lock_rows(t.entry, t.n, t.q_lock, g0, rows);
  // The bottom sphere: depth + n·dp <= upper.
  QpRow bottom;
  bottom.a.head<3>() = -t.n;
  bottom.b = depth - limits.upper;
  add(bottom, RowKind::TunnelBottom, TunnelRow::Bottom);
  // The tissue's hold: depth + n·dp >= lower (eq. 9: p_s(k) = p_s(k-1) until |F_e| > F_e*).
  QpRow hold;
  hold.a.head<3>() = t.n;
  hold.b = limits.lower - depth;
  add(hold, RowKind::TunnelHold, TunnelRow::Hold);
}

bool update_engagement(const Params& p, StateImpl& s, const Pose& haptic) {
  Engagement& e = s.engaged;
  if (s.tip.lesion < 0) {
    e.last_hand = haptic.p;
    return e.active = false;
  }
  // Eqs. 3-4's press along the tip axis, as for entry.
  const Material& mat = p.materials[s.tip.material];
  const Vec3 n = -(s.graphic.q * Vec3::UnitZ());
  const Vec3 pull = haptic.p - s.graphic.p;
  const double f_p = mat.k_e * std::max(pull.dot(n), 0.0);
  // The hand's motion this cycle: a press moves along the axis, a slide across it.
  const Vec3 moved = haptic.p - e.last_hand;
  e.last_hand = haptic.p;
  const double across = (moved - n * moved.dot(n)).norm();
  const bool sliding = across > kSlideMotion && across > kSlideSlope * std::abs(moved.dot(n));
  // Catch on a press, let go when the press is gone or the hand slides.
  if (!e.active && f_p > kEngageShare * mat.f_p_star && !sliding) {
    e.active = true;
    e.point = s.graphic.p;
    e.n = n;
    e.q = s.graphic.q;
  } else if (e.active && (!(f_p > kReleaseShare * mat.f_p_star) || sliding)) {
    e.active = false;
  }
  return e.active;
}

void build_engagement_rows(const Engagement& e, const Pose& g0, RowSet& rows) {
  // The tip stays on its axis line and the orientation where it caught (as the tunnel, Fig. 5, eq. 7).
  add_axis_lock_rows(e.point, e.n, e.q, g0, rows);
}

bool try_enter_penetration(const Model& m, const Params& p, StateImpl& s, const Pose& haptic) {
  if (s.tip.lesion < 0) return false;
  const Material& mat = p.materials[s.tip.material];
  // Eqs. 3-4: F_c = k_e (p_h^t - p_g^{t-1}); F_p = -(F_c·n)n along the tip axis n (tool -z).
  const Vec3 n = -(s.graphic.q * Vec3::UnitZ());
  const double push = (haptic.p - s.graphic.p).dot(n);
  const double f_p = mat.k_e * std::max(push, 0.0);
  if (!(f_p > mat.f_p_star)) return false;

  // Open the tunnel at the tip's current place.
  const LesionModel& lesion = m.lesions[s.tip.lesion];
  Tunnel& t = s.tunnel;
  t.entry = s.graphic.p;
  t.n = n;
  t.q_lock = s.graphic.q;
  t.depth = 0.0;
  // Depth is counted from the lesion's surface along the axis (docs/penetration.md "Depth"): the
  // apex has already sunk into the soft surface before it breaks in.
  const double sunk = surface_depth(m.objects[lesion.object], s.graphic.p + n * m.tool.tip_radius, n,
                                    kSurfaceReach, &s.collision.budget);
  t.depth0 = std::isfinite(sunk) ? sunk : s.tip.sink;
  t.lesion = s.tip.lesion;
  t.object = lesion.object;
  t.material = s.tip.material;
  // The lesion's bottom is a hard stop: the tip's apex may travel until it leaves the lesion volume.
  t.max_depth = std::max(0.0, lesion_exit(lesion.shape, t.entry, n) - m.tool.tip_radius);
  release_anchors(s.anchors);
  s.engaged.active = false;
  s.interaction = InteractionState::Inserting;
  return true;
}

TunnelLimits tunnel_limits(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt) {
  const Tunnel& t = s.tunnel;
  const Material& mat = p.materials[t.material];

  // Eqs. 3-4 and 8: the force along the axis, pushing in (F_p) or pulling out (F_e).
  const double along = (haptic.p - s.graphic.p).dot(t.n);
  const double f_p = mat.k_e * std::max(along, 0.0);
  const double f_e = mat.k_e * std::max(-along, 0.0);
  const double scale = dt / m.settings.reference_dt;  // eq. 5 is per 1 ms cycle
  const double apex_depth = t.depth0 + t.depth;

  // Sub-state switches: a strong pull starts extraction, a strong push resumes insertion.
  if (s.interaction == InteractionState::Inserting && f_e > mat.f_e_star)
    s.interaction = InteractionState::Extracting;
  else if (s.interaction == InteractionState::Extracting && f_p > mat.f_p_star)
    s.interaction = InteractionState::Inserting;

  TunnelLimits out{&t, t.depth, t.depth};
  const double k_c = mat.k_c.at(apex_depth);
  const double resistance = insertion_resistance(mat, apex_depth);
  if (s.interaction == InteractionState::Inserting && f_p > resistance) {
    // Advance to where |F_p| = R(d), bounded by eq. 5's increment (rate independent) and the give
    // speed.
    double delta = along - resistance / mat.k_e;
    delta = std::min(delta, f_p / k_c * scale);
    delta = std::min(delta, m.settings.max_give_speed * dt);
    out.upper = std::min(t.depth + std::max(delta, 0.0), std::max(t.depth, t.max_depth));
  } else if (s.interaction == InteractionState::Extracting && f_e > mat.f_e_star) {
    // Eqs. 8-9: beyond F_e* the probe slides out, the tunnel shortening behind it.
    double delta = f_e / k_c * scale;
    delta = std::min(delta, -along - mat.f_e_star / mat.k_e);
    out.lower = std::max(t.depth - std::max(delta, 0.0), 0.0);
  }
  return out;
}

void penetration_step(const Model& m, const Params& p, StateImpl& s, const Pose& haptic, double dt,
                      StepTrace& trace) {
  Tunnel& t = s.tunnel;
  const Material& mat = p.materials[t.material];
  const Pose g_prev = s.graphic;
  const TunnelLimits limits = tunnel_limits(m, p, s, haptic, dt);

  // One optimisation: tunnel rows + additional contacts with every other object (Fig. 7), pulled by
  // the tunnel's stiffness (eq. 6's k_p: the device's maximum stiffness; eq. 7's k_θ).
  SubstepRequest req;
  req.target = config_difference(haptic, g_prev);
  req.G.setZero();
  req.G.diagonal() << p.limits.max_stiffness, p.limits.max_stiffness, p.limits.max_stiffness, mat.k_theta,
      mat.k_theta, mat.k_theta;
  req.trans_bound = std::max(limits.upper - t.depth, t.depth - limits.lower) + 1e-6;
  req.rot_bound = 1e-6;
  req.mask = s.constants.all_mask & ~(ObjectMask{1} << t.object);
  req.friction = false;
  req.hold_only = true;
  req.tunnel = &limits;
  bool reached = false;
  s.graphic = solve_substep(m, p, s, g_prev, req, trace, reached);
  t.depth = std::max(0.0, (s.graphic.p - t.entry).dot(t.n));
  trace.substeps = 1;

  // Full extraction: the tunnel disappears and the state returns to sliding.
  if (s.interaction == InteractionState::Extracting && t.depth <= kExitDepth) {
    s.interaction = InteractionState::Sliding;
    t.lesion = -1;
    s.tip.lesion = -1;
  }
}

void tunnel_spheres(const Model& m, const StateImpl& s, TunnelSpheres& out) {
  const Tunnel& t = s.tunnel;
  out.active = t.lesion >= 0 && penetrating(s.interaction);
  if (!out.active) return;
  out.entry = t.entry;
  out.axis = t.n;
  out.max_depth = t.depth0 + t.max_depth;
  const double r_tip = m.tool.tip_radius;
  const Vec3 tip = t.entry + t.n * t.depth;
  out.centers[0] = tip + t.n * (r_tip + kBottomRadius);
  out.radii[0] = kBottomRadius;
  Vec3 side[2];
  tangent_basis(t.n, side[0], side[1]);
  for (int j = 0; j < 4; ++j) {
    const Vec3 dir = (j % 2 == 0 ? 1.0 : -1.0) * side[j / 2];
    out.centers[1 + j] = tip + dir * (r_tip + kBottomRadius);
    out.radii[1 + j] = kBottomRadius;
  }
}

}  // namespace cariesim::detail

namespace cariesim {

double insertion_resistance(const Material& caries, double apex_depth) {
  return caries.k_c.at(apex_depth) * caries.crush_length;
}

}  // namespace cariesim
