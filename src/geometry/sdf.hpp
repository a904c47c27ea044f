#pragma once
/// Signed-distance helpers of the procedural shapes (procedural.cpp, tooth.cpp; private to the
/// geometry module). Distances in mm, negative inside.

#include <algorithm>
#include <cmath>

namespace cariesim::sdf {

/// x².
inline double sq(double x) { return x * x; }

/// Hermite step: 0 below edge0, 1 above edge1, 3t² - 2t³ between (t the position in [edge0, edge1]).
inline double smoothstep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

/// Signed distance (mm) to a centred rectangle of half extents (hx, hy) (mm) with corner radius r (mm).
inline double rounded_rect(double x, double y, double hx, double hy, double r) {
  r = std::min({r, hx, hy});
  const double qx = std::abs(x) - (hx - r);
  const double qy = std::abs(y) - (hy - r);
  return std::sqrt(sq(std::max(qx, 0.0)) + sq(std::max(qy, 0.0))) + std::min(std::max(qx, qy), 0.0) - r;
}

/// Polynomial smooth minimum of width k (mm): equal to min(a, b) when |a - b| >= k.
inline double smin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

/// Polynomial smooth maximum of width k (mm): equal to max(a, b) when |a - b| >= k.
inline double smax(double a, double b, double k) { return -smin(-a, -b, k); }

}  // namespace cariesim::sdf
