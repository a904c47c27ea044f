// Tight sphere trees (docs/design.md §3): inscribed spheres under the surface whose union follows the
// surface to a tolerance, plus a few large filler spheres inside (the leaves: build_tree fits the
// inner levels over them).
//
// The surface leaves come from a greedy cover of dense surface samples (spacing 2 x tolerance). For
// a sample x with outward normal n, the largest sphere tangent at x is centred at c = x - r n, r the
// largest radius up to max_radius for which the sphere still stays inside: D(c) + r <= eps, found by
// bisection on the signed distance D. An uncovered sample gets its tangent sphere, and every sample
// within `tolerance` of that sphere counts as covered; flat regions thus get few large spheres and
// ridges many small ones. The cover starts with a sparse set of scouts sorted by radius (largest
// first) and then sweeps every sample still uncovered. Each sphere is finally clipped so that it
// reaches past no surface sample by more than a fifth of the tolerance: that check is exact against
// the samples, so the coarse deep part of D (beyond the narrow band) only guides the radius search.

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/spheretree/hierarchy.hpp"
#include "cariesim/spheretree/lesion.hpp"
#include "spheretree/build_support.hpp"

namespace cariesim::detail {

namespace {

// Surface sample spacing per unit of tolerance, and the sample budget.
constexpr double kSpacingPerTolerance = 2.0;
constexpr double kMaxSamples = 1.5e6;
// Bisection steps for a tangent sphere's radius.
constexpr int kBisectionSteps = 11;
// A sample's own sphere must reach it within this fraction of the tolerance (by the distance field,
// whose deep part is coarse; the sample check below is exact).
constexpr double kReachFraction = 0.5;
// One sample in kScoutStride gets its tangent sphere up front to order the cover.
constexpr uint32_t kScoutStride = 8;
// A sphere may reach past a surface sample by at most this fraction of the tolerance.
constexpr double kPokeFraction = 0.2;
// Filler spheres stay this many tolerances (at least one voxel) inside the surface.
constexpr double kFillerMarginTolerances = 2.0;
// Attempts at a sample's sphere when the sample check shrinks it below reaching the sample.
constexpr int kPlacementAttempts = 3;

// One surface sample: a point on the zero set and the outward unit normal there.
// A covered sample whose normal turns further than this from the seed's (cos 30 degrees) makes a
// second tangent of the sphere.
constexpr double kSecondTangentCos = 0.866;

struct Sample {
  Vec3 x;
  Vec3 n;
  double reach = 0.0;  // mm, radius of the largest tangent sphere found for it
};

// Projects a point onto the zero set along the gradient (one Newton step: the points come from the
// zero set's own mesh, so they start within a small fraction of a voxel) and returns the normal.
Sample project(DistanceField::Probe& probe, const Vec3& p) {
  Sample s{p, Vec3::UnitZ()};
  const Vec3 g = probe.gradient(s.x);
  if (g.isZero()) return s;
  s.x -= probe.distance(s.x) * g;
  const Vec3 n = probe.gradient(s.x);
  s.n = n.isZero() ? g : n;
  return s;
}

// No limit on a sphere beyond staying inside the solid.
struct NoLimit {
  bool operator()(const Vec3& /*center*/, double /*radius*/) const { return true; }
};

// Largest r in [0, max_r] whose tangent sphere at the sample still reaches it (D(x - r n) + r <= eps)
// and that `fits` accepts (a predicate that, once false, stays false for larger spheres).
template <typename Fits = NoLimit>
double tangent_radius(DistanceField::Probe& probe, const Sample& s, double max_r, double eps,
                      Fits fits = {}) {
  const auto ok = [&](double r) {
    const Vec3 c = s.x - r * s.n;
    return probe.distance(c) + r <= eps && fits(c, r);
  };
  if (ok(max_r)) return max_r;
  double lo = 0.0;
  double hi = max_r;
  for (int i = 0; i < kBisectionSteps; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (ok(mid)) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

// What a greedy cover needs besides the samples.
struct CoverSettings {
  double tolerance = 0.015;  // mm
  double max_radius = 1.0;   // mm
  double min_radius = 0.02;  // mm
  std::size_t max_leaves = 50000;
  const char* stage = "tight";  // progress prefix
};

// Greedy cover of the samples `raw` (those with covered[i] set are only checked against, never
// seeded) by spheres tangent to the zero set of `field`, each accepted by `fits`; appends the spheres
// to `leaves` and returns whether the leaf cap stopped it.
template <typename Fits>
bool cover_samples(const std::vector<Vec3>& raw, std::vector<uint8_t>& covered, const PointIndex& index,
                   const DistanceField& field, const CoverSettings& cfg, Fits fits,
                   const ProgressFn& progress, std::vector<LeafSphere>& leaves) {
  const double tol = cfg.tolerance;
  bool capped = false;
  // Scouts: every kScoutStride-th sample, projected with its largest tangent sphere found up front
  // (parallel), so the cover can start with the largest spheres.
  report(progress, std::string(cfg.stage) + ": tangent spheres", 0.1);
  const double reach_eps = kReachFraction * tol;
  std::vector<uint32_t> order;
  for (uint32_t i = 0; i < raw.size(); i += kScoutStride)
    if (!covered[i]) order.push_back(i);
  std::vector<Sample> scouts(order.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, order.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      DistanceField::Probe probe(field);
                      for (std::size_t k = range.begin(); k != range.end(); ++k) {
                        scouts[k] = project(probe, raw[order[k]]);
                        scouts[k].reach = tangent_radius(probe, scouts[k], cfg.max_radius, reach_eps, fits);
                      }
                    });
  std::vector<uint32_t> by_reach(order.size());
  std::iota(by_reach.begin(), by_reach.end(), 0u);
  std::stable_sort(by_reach.begin(), by_reach.end(),
                   [&](uint32_t a, uint32_t b) { return scouts[a].reach > scouts[b].reach; });

  // Greedy cover: the scouts largest sphere first, then every sample still uncovered, in sample
  // order (triangle by triangle). Deterministic: ties keep the sample order.
  report(progress, std::string(cfg.stage) + ": cover", 0.3);
  PointIndex::Query query(index);
  DistanceField::Probe probe(field);
  std::vector<std::size_t> near;
  const double poke = kPokeFraction * tol;
  std::size_t unplaced = 0;
  const std::size_t steps = by_reach.size() + raw.size();
  for (std::size_t step = 0; step < steps && !capped; ++step) {
    const bool scouting = step < by_reach.size();
    const uint32_t i = scouting ? order[by_reach[step]] : static_cast<uint32_t>(step - by_reach.size());
    if (covered[i]) continue;
    covered[i] = 1;
    if (leaves.size() >= cfg.max_leaves) {
      capped = true;
      break;
    }
    if (step % 8192 == 0)
      report(progress, std::string(cfg.stage) + ": cover", 0.3 + 0.5 * static_cast<double>(step) / steps);
    Sample s = scouting ? scouts[by_reach[step]] : project(probe, raw[i]);
    if (!scouting) s.reach = tangent_radius(probe, s, cfg.max_radius, reach_eps, fits);

    // The sphere tangent at the sample, never reaching past a surface sample by more than `poke`
    // (exact against the samples, whatever the error of the deep distance); when that shrinks it
    // so much that it no longer reaches its own sample, try again with the reach capped there.
    Vec3 c;
    double r = 0.0;
    for (int attempt = 0; attempt < kPlacementAttempts; ++attempt) {
      c = s.x - s.reach * s.n;
      r = s.reach;
      near.clear();
      query.for_each_within(c, r + tol, [&](std::size_t j) { near.push_back(j); });
      for (std::size_t j : near) r = std::min(r, (raw[j] - c).norm() + poke);
      if (s.reach - r <= tol || !(r > cfg.min_radius)) break;
      s.reach = tangent_radius(probe, s, r, reach_eps, fits);
    }
    if (!(r >= cfg.min_radius)) {
      ++unplaced;
      continue;
    }
    // Every sample within the tolerance of the sphere is covered. The sphere is tangent to the
    // surface at its seed sample; if it also touches a differently facing part of the surface (the
    // other face at an edge, the floor of a thin layer), that is its second tangent.
    const Vec3 seed_normal = s.n.normalized();
    double least_aligned = kSecondTangentCos;
    Vec3 second = Vec3::Zero();
    for (std::size_t j : near) {
      if ((raw[j] - c).norm() - r > tol) continue;
      covered[j] = 1;
      const Vec3 n = probe.gradient(raw[j]);
      const double alignment = n.dot(seed_normal);
      if (n.norm() > 0.5 && alignment < least_aligned) least_aligned = alignment, second = n.normalized();
    }
    LeafSphere leaf{};
    leaf.center = c.cast<float>();
    leaf.radius = static_cast<float>(r);
    leaf.flags = kLeafOnExposedSurface;
    leaf.depth = static_cast<float>(-probe.distance(c));
    leaf.tangents.normal[0] = seed_normal.cast<float>();
    leaf.tangents.count = 1;
    if (second.squaredNorm() > 0.5) {
      leaf.tangents.normal[1] = second.cast<float>();
      leaf.tangents.count = 2;
    }
    leaves.push_back(leaf);
  }
  if (capped) {
    spdlog::warn("tight tree: the leaf cap ({}) was reached before the surface was covered", cfg.max_leaves);
    report(progress, "tight: leaf cap reached", 0.8);
  }
  if (unplaced > 0) {
    spdlog::debug("tight tree: {} samples needed a sphere smaller than min_radius {} mm", unplaced,
                  cfg.min_radius);
  }

  return capped;
}

}  // namespace

TreeLeaves build_tight_leaves(const LevelSet& shape, const TreeParams& params, const ProgressFn& progress) {
  const double tol = params.tolerance;
  const double voxel = shape.voxel_size();
  TreeLeaves out;
  out.mode = TreeMode::Tight;
  std::vector<LeafSphere>& leaves = out.leaves;

  // Dense samples on the zero set, spaced by the tolerance (within the budget).
  report(progress, "tight: surface", 0.0);
  const TriangleMesh surface = shape.to_mesh(0.0);
  const double area = surface.area();
  if (!(area > 0.0)) return out;
  const double spacing = std::max(kSpacingPerTolerance * tol, std::sqrt(area / kMaxSamples));
  const std::vector<Vec3> raw = sample_surface_stratified(surface, 1.0 / (spacing * spacing), 1);
  const Eigen::AlignedBox3d box = surface.bounds();

  // The distance field must resolve depths down to the largest sphere.
  const DistanceField field(shape, params.max_radius + tol);

  // Greedy cover of every sample.
  const PointIndex index(raw, 4.0 * spacing);
  std::vector<uint8_t> covered(raw.size(), 0);
  CoverSettings cfg;
  cfg.tolerance = tol;
  cfg.max_radius = params.max_radius;
  cfg.min_radius = params.min_radius;
  cfg.max_leaves = params.max_leaves;
  const bool capped = cover_samples(raw, covered, index, field, cfg, NoLimit{}, progress, leaves);
  PointIndex::Query query(index);

  // Filler spheres: a grid of interior points, each inside some leaf; deepest uncovered point first.
  if (params.fill_interior && !capped) {
    report(progress, "tight: interior", 0.8);
    const double step = std::max(0.5 * params.max_radius, 2.0 * voxel);
    const double margin = std::max(kFillerMarginTolerances * tol, voxel);
    // Filler radii are clipped against the surface samples, so a coarse deep distance will do.
    const DistanceField deep(shape, 0.5 * box.sizes().maxCoeff(), 0.0, step);
    DistanceField::Probe deep_probe(deep);
    std::vector<Vec3> points;
    std::vector<double> depth;
    for (double x = box.min().x() + 0.5 * step; x < box.max().x(); x += step) {
      for (double y = box.min().y() + 0.5 * step; y < box.max().y(); y += step) {
        for (double z = box.min().z() + 0.5 * step; z < box.max().z(); z += step) {
          const Vec3 p(x, y, z);
          const double d = -deep_probe.distance(p);
          if (d > 0.5 * step) {
            points.push_back(p);
            depth.push_back(d);
          }
        }
      }
    }
    if (!points.empty()) {
      const PointIndex interior(points, step);
      PointIndex::Query inner(interior);
      std::vector<uint8_t> inside(points.size(), 0);
      const auto mark = [&](const Vec3& c, double r) {
        inner.for_each_within(c, r, [&](std::size_t j) { inside[j] = 1; });
      };
      for (const LeafSphere& l : leaves) mark(l.center.cast<double>(), l.radius);
      std::vector<uint32_t> deepest(points.size());
      std::iota(deepest.begin(), deepest.end(), 0u);
      std::stable_sort(deepest.begin(), deepest.end(),
                       [&](uint32_t a, uint32_t b) { return depth[a] > depth[b]; });
      for (uint32_t i : deepest) {
        if (inside[i] || leaves.size() >= params.max_leaves) continue;
        inside[i] = 1;
        // Inscribed with a margin, checked against the surface samples (the deep distance is coarse).
        double r = depth[i] - margin;
        query.for_each_within(points[i], r + margin,
                              [&](std::size_t j) { r = std::min(r, (raw[j] - points[i]).norm() - margin); });
        if (r < params.min_radius) continue;
        mark(points[i], r);
        LeafSphere leaf{};
        leaf.center = points[i].cast<float>();
        leaf.radius = static_cast<float>(r);
        leaf.flags = kLeafInterior;
        leaf.depth = static_cast<float>(depth[i]);
        leaves.push_back(leaf);
      }
    }
  }

  report(progress, "tight: done", 1.0);
  return out;
}

}  // namespace cariesim::detail

namespace cariesim {

std::vector<std::vector<LeafSphere>> build_seam_leaves(const LevelSet& object,
                                                       std::span<const LesionShape> lesions,
                                                       const TreeParams& params, const SeamParams& seam,
                                                       const ProgressFn& progress) {
  using namespace detail;
  std::vector<std::vector<LeafSphere>> parts(lesions.size() + 1);
  if (lesions.empty() || object.empty()) return parts;
  const double tol = seam.tolerance_for(params.tolerance);
  const double overlap = seam.overlap_mm;

  // The part that owns a point (0 healthy, 1 + k the k-th lesion's caries: the first lesion holding
  // it, as the CSG cuts them) and how far the point lies inside that part, away from its cuts.
  const auto owner = [&](const Vec3& p, double& room) {
    double prior = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < lesions.size(); ++k) {
      const double d = lesions[k].distance(p);
      if (d < 0.0) {
        room = std::min(-d, prior);
        return static_cast<int>(k) + 1;
      }
      prior = std::min(prior, d);
    }
    room = prior;
    return 0;
  };
  const auto border = [&](const Vec3& p) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const LesionShape& l : lesions) nearest = std::min(nearest, std::abs(l.distance(p)));
    return nearest;
  };

  // Samples of the uncut surface: those within the band get covered, those a little further only
  // bound the spheres (no sphere may reach past a sample by more than the builder's poke).
  report(progress, "seam: surface", 0.0);
  const TriangleMesh surface = object.to_mesh(0.0);
  const double spacing = kSpacingPerTolerance * tol;
  const double max_r = std::min(params.max_radius, seam.band_mm + overlap);
  const double check = seam.band_mm + max_r + tol;
  std::vector<Vec3> raw;
  {
    // The triangles that may reach the checked band (|border| is 1-Lipschitz), sampled at the builder's
    // density.
    TriangleMesh near_band;
    for (const auto& t : surface.triangles) {
      const Vec3 a = surface.vertices[t[0]].cast<double>();
      const Vec3 b = surface.vertices[t[1]].cast<double>();
      const Vec3 c = surface.vertices[t[2]].cast<double>();
      const Vec3 m = (a + b + c) / 3.0;
      const double reach = std::max({(a - m).norm(), (b - m).norm(), (c - m).norm()});
      if (border(m) > check + reach) continue;
      const auto base = static_cast<uint32_t>(near_band.vertices.size());
      near_band.vertices.push_back(a.cast<float>());
      near_band.vertices.push_back(b.cast<float>());
      near_band.vertices.push_back(c.cast<float>());
      near_band.triangles.push_back({base, base + 1, base + 2});
    }
    for (const Vec3& p : sample_surface_stratified(near_band, 1.0 / (spacing * spacing), 1))
      if (border(p) <= check) raw.push_back(p);
  }
  if (raw.empty()) return parts;
  std::vector<uint8_t> covered(raw.size(), 0);
  for (std::size_t i = 0; i < raw.size(); ++i) covered[i] = border(raw[i]) > seam.band_mm ? 1 : 0;

  // Tangent spheres inside the object that reach at most `overlap` across a cut into another part.
  const DistanceField field(object, max_r + tol);
  const PointIndex index(raw, 4.0 * spacing);
  CoverSettings cfg;
  cfg.tolerance = tol;
  cfg.max_radius = max_r;
  cfg.min_radius = std::min(params.min_radius, 0.5 * overlap);
  cfg.max_leaves = params.max_leaves;
  cfg.stage = "seam";
  const auto fits = [&](const Vec3& c, double r) {
    double room = 0.0;
    owner(c, room);
    return room >= r - overlap;
  };
  std::vector<LeafSphere> leaves;
  cover_samples(raw, covered, index, field, cfg, fits, progress, leaves);
  for (const LeafSphere& leaf : leaves) {
    double room = 0.0;
    parts[static_cast<std::size_t>(owner(leaf.center.cast<double>(), room))].push_back(leaf);
  }
  report(progress, "seam: done", 1.0);
  return parts;
}

void add_seam_leaves(TreeLeaves& part, std::span<const LeafSphere> seam_leaves, const LevelSet& object,
                     std::span<const LesionShape> lesions, const TreeParams& params, const SeamParams& seam) {
  using namespace detail;
  if (part.mode != TreeMode::Tight) {
    throw Error("add_seam_leaves: seam leaves join a tight tree's leaves (an octree's leaves are its cells)");
  }
  std::vector<LeafSphere>& leaves = part.leaves;
  // The part's own leaves that poke out of the uncut surface within the seam band (by up to the reach
  // slack of their coarser build) are shrunk to the seam leaves' poke. A leaf's poke-out is the cap
  // around its apex toward the nearest surface, c + r g (g the distance's gradient at c): it lies in
  // the band when the apex is within the band plus the cap's radius.
  const double poke = kPokeFraction * seam.tolerance_for(params.tolerance);
  const DistanceField field(object, 0.0, 0.0);
  DistanceField::Probe probe(field);
  std::size_t kept = 0;
  for (LeafSphere& leaf : leaves) {
    const Vec3 c = leaf.center.cast<double>();
    const double d = probe.distance(c);
    const double out = leaf.radius + d;
    if (out > poke && std::abs(d) < field.reliable_band()) {
      const Vec3 apex = c + double(leaf.radius) * probe.gradient(c);
      double border = std::numeric_limits<double>::infinity();
      for (const LesionShape& l : lesions) border = std::min(border, std::abs(l.distance(apex)));
      if (border <= seam.band_mm + std::sqrt(2.0 * leaf.radius * out))
        leaf.radius = static_cast<float>(poke - d);
    }
    if (leaf.radius > 0.0f) leaves[kept++] = leaf;
  }
  leaves.resize(kept);
  leaves.insert(leaves.end(), seam_leaves.begin(), seam_leaves.end());
}

}  // namespace cariesim
