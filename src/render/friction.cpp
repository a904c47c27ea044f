// Friction on caries in the sliding state (paper §3.2, Figs. 10-11; DESIGN.md §4 step 4).
//
// A loaded contact region on frictional tissue sticks: its tool point is held at an anchor in the
// tangent plane by two equality rows t_j·(dp + dθ × a) = t_j·(anchor - x). Their multipliers are the
// tangential force. While it stays inside the static cone |f_t| <= mu_s·f_n the anchor holds; once it
// leaves, the contact slips: the anchor moves toward where the tool would go so that the tangential
// force falls to the dynamic cone mu_d·f_n, and the build-up starts again. This stick-slip cycle is
// the saw-tooth of the paper's force signals. Anisotropic friction (paper §2.1) uses an elliptic cone
// with other coefficients along the material's direction than across it.
#include <algorithm>
#include <cmath>

#include "render/internal.hpp"

namespace cariesim::detail {

namespace {

constexpr double kMinNormalForce = 1e-6;     // N: below this a contact carries no friction
constexpr double kRigidSlipStiffness = 1e3;  // N/mm: a rigid row's share of the slip stiffness

// An orthonormal tangent pair for a unit normal.
void tangent_basis(const Vec3& n, Vec3& t1, Vec3& t2) {
  const Vec3 helper = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  t1 = n.cross(helper).normalized();
  t2 = n.cross(t1);
}

int find_region(const StateImpl& s, const FrictionAnchor& a) {
  for (int r = 0; r < s.region_count; ++r) {
    const Region& reg = s.regions[r];
    if (reg.object == a.object && (reg.tool_point_local - a.point_local).norm() < kRegionRadius) return r;
  }
  return -1;
}

// The cone's axes in the tangent plane and the coefficients along them.
struct Cone {
  Vec3 u, v;
  double mu_s_u, mu_s_v, mu_d_u, mu_d_v;
};

Cone cone_of(const Material& mat, const Vec3& n) {
  Cone c;
  const Vec3 dir = mat.aniso_dir - n * n.dot(mat.aniso_dir);
  if (dir.norm() > 1e-9) {
    c.u = dir.normalized();
    c.v = n.cross(c.u);
    c.mu_s_u = mat.mu_s_along;
    c.mu_d_u = mat.mu_d_along;
  } else {
    tangent_basis(n, c.u, c.v);
    c.mu_s_u = mat.mu_s;
    c.mu_d_u = mat.mu_d;
  }
  c.mu_s_v = mat.mu_s;
  c.mu_d_v = mat.mu_d;
  // A dynamic coefficient above the static one would make slipping harder than sticking.
  c.mu_d_u = std::min(c.mu_d_u, c.mu_s_u);
  c.mu_d_v = std::min(c.mu_d_v, c.mu_s_v);
  return c;
}

// Elliptic cone measure: the normal force at which (f_u, f_v) lies exactly on the cone.
double cone_measure(double f_u, double f_v, double mu_u, double mu_v) {
  const auto term = [](double f, double mu) {
    if (std::abs(f) < 1e-15) return 0.0;
    return mu > 1e-12 ? (f / mu) * (f / mu) : std::numeric_limits<double>::infinity();
  };
  return std::sqrt(term(f_u, mu_u) + term(f_v, mu_v));
}

}  // namespace

void add_friction_rows(StateImpl& s, const Pose& g, uint32_t& flags) {
  for (int k = 0; k < kMaxAnchors; ++k) {
    FrictionAnchor& a = s.anchors[k];
    a.rows[0] = a.rows[1] = -1;
    if (!a.active) continue;
    // The anchor's region is gone: the tool left the surface.
    const int r = find_region(s, a);
    if (r < 0) {
      a.active = false;
      continue;
    }
    a.region = static_cast<int16_t>(r);
    const Vec3 x = g.transform(a.point_local);
    const Vec3 lever = x - g.p;
    const Vec3& n = s.regions[r].normal;
    // The anchor lies in the contact's tangent plane: drop the offset along the normal (a tool
    // sinking into compliant tissue leaves its anchor above it), which a later, tilted normal would
    // otherwise turn into a sideways pull.
    a.anchor -= n * n.dot(a.anchor - x);
    tangent_basis(n, a.tangents[0], a.tangents[1]);
    for (int j = 0; j < 2; ++j) {
      QpRow row;
      row.a.head<3>() = a.tangents[j];
      row.a.tail<3>() = lever.cross(a.tangents[j]);
      row.b = a.tangents[j].dot(a.anchor - x);
      row.equality = true;
      row.key = 0xF1C0000000000000ull | static_cast<uint64_t>(2 * k + j);
      if (!s.problem.add(row)) {
        flags |= kFlagQpRowsFull;
        return;
      }
      a.rows[j] = static_cast<int8_t>(s.problem.row_count - 1);
      s.meta[s.problem.row_count - 1] =
          RowMeta{RowKind::Friction, static_cast<int16_t>(r), static_cast<int16_t>(k), -1};
    }
  }
}

int slip_anchors(const Params& p, StateImpl& s, const Pose& g, const Mat6& G, int& slipped) {
  int changed = 0;
  for (FrictionAnchor& a : s.anchors) {
    if (!a.active || a.rows[0] < 0 || a.rows[1] < 0) continue;
    const Region& reg = s.regions[a.region];
    const double f_n = reg.normal_force;
    // No normal load: the contact is separating and cannot hold.
    if (f_n <= kMinNormalForce) {
      a.active = false;
      ++changed;
      continue;
    }
    const Vec3 f_t = s.result.lambda[a.rows[0]] * a.tangents[0] + s.result.lambda[a.rows[1]] * a.tangents[1];
    const Cone cone = cone_of(p.materials[reg.material], reg.normal);
    const double f_u = f_t.dot(cone.u);
    const double f_v = f_t.dot(cone.v);
    // Inside the static cone: stick.
    if (cone_measure(f_u, f_v, cone.mu_s_u, cone.mu_s_v) <= f_n) continue;

    // Slip: scale the tangential load onto the dynamic cone by moving the anchor toward where the
    // unconstrained tool would be. The load is linear in the anchor offset with the effective
    // tangential stiffness seen at this point: the coupling (translation and rotation in series) plus
    // every loaded contact row that resists motion along the load (tissue stiffness, or
    // kRigidSlipStiffness for rigid rows). Without the contacts' share a tool pressed sideways into
    // stiff tissue would throw its anchor far past where the tissue lets it go.
    const double q_d = cone_measure(f_u, f_v, cone.mu_d_u, cone.mu_d_v);
    const double scale = std::isfinite(q_d) && q_d > 0.0 ? std::min(1.0, f_n / q_d) : 0.0;
    const double f_t_norm = f_t.norm();
    const Vec3 dir = f_t / f_t_norm;
    const Vec3 lever = g.q * a.point_local;
    const double k_t = G(0, 0), k_r = G(3, 3);
    double k_eff = 1.0 / (1.0 / k_t + lever.cross(dir).squaredNorm() / k_r);
    for (int row = 0; row < s.problem.row_count; ++row) {
      if (s.meta[row].kind != RowKind::Contact || s.result.lambda[row] <= 0.0) continue;
      const QpRow& qr = s.problem.rows[row];
      const double along = qr.a.head<3>().dot(dir);
      k_eff += along * along * (qr.compliance > 0.0 ? 1.0 / qr.compliance : kRigidSlipStiffness);
    }
    a.anchor -= (1.0 - scale) * f_t / k_eff;
    ++changed;
    ++slipped;
  }
  return changed;
}

void create_anchors(const Params& p, StateImpl& s, const Pose& g) {
  for (int r = 0; r < s.region_count; ++r) {
    const Region& reg = s.regions[r];
    if (!p.materials[reg.material].frictional() || reg.normal_force <= kMinNormalForce) continue;
    bool anchored = false;
    for (const FrictionAnchor& a : s.anchors)
      anchored = anchored || (a.active && a.object == reg.object &&
                              (reg.tool_point_local - a.point_local).norm() < kRegionRadius);
    if (anchored) continue;
    for (FrictionAnchor& a : s.anchors) {
      if (a.active) continue;
      a.active = true;
      a.object = reg.object;
      a.point_local = reg.tool_point_local;
      a.anchor = g.transform(reg.tool_point_local);
      a.region = static_cast<int16_t>(r);
      break;
    }
  }
}

void release_anchors(StateImpl& s) {
  for (FrictionAnchor& a : s.anchors) a.active = false;
}

}  // namespace cariesim::detail
