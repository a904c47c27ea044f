#include "cariesim/geometry/mesh.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include "cariesim/common/error.hpp"
#include "geometry/mesh_checks.hpp"

namespace cariesim {

namespace {

using Triangle = std::array<uint32_t, 3>;

// A triangle whose cross product is below this fraction of its longest edge squared has zero area
// (its height is under 1e-10 of its length: collinear within float precision).
constexpr double kZeroAreaRelative = 1e-10;
// A small hole is only filled when its loop is shorter than this fraction of the bounding-box diagonal,
// so that a whole open side (or a lone sheet) is reported instead of being capped.
constexpr double kMaxHolePerimeterFraction = 0.25;
// A closed mesh must enclose more than this fraction of its bounding-box diagonal cubed.
constexpr double kMinVolumeFraction = 1e-9;
// Triangle tests the nested-shell check may spend (a second or two): a file of shells packed within
// one another's bounds beyond that is refused rather than checked for minutes.
constexpr std::size_t kMaxNestingWork = 20'000'000;

[[noreturn]] void fail(const std::string& what, const std::string& problem) {
  throw Error(fmt::format("{}: {}", what, problem));
}

uint64_t edge_key(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t{a} << 32) | b : (uint64_t{b} << 32) | a;
}

Vec3 position(const TriangleMesh& mesh, uint32_t i) { return mesh.vertices[i].cast<double>(); }

// Twice the area of a triangle and its longest edge length squared.
std::pair<double, double> area2_and_longest2(const TriangleMesh& mesh, const Triangle& t) {
  const Vec3 a = position(mesh, t[0]);
  const Vec3 b = position(mesh, t[1]);
  const Vec3 c = position(mesh, t[2]);
  const double longest2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  return {(b - a).cross(c - a).norm(), longest2};
}

bool zero_area(const TriangleMesh& mesh, const Triangle& t) {
  const auto [area2, longest2] = area2_and_longest2(mesh, t);
  return area2 <= kZeroAreaRelative * longest2;
}

// Merges vertices with bit-identical coordinates (-0 and +0 are the same) and renumbers triangles.
std::size_t weld_vertices(TriangleMesh& mesh) {
  struct KeyHash {
    std::size_t operator()(const std::array<uint32_t, 3>& k) const {
      return (std::size_t{k[0]} * 0x9E3779B97F4A7C15ull) ^ (std::size_t{k[1]} * 0xC2B2AE3D27D4EB4Full) ^
             (std::size_t{k[2]} * 0x165667B19E3779F9ull);
    }
  };
  std::unordered_map<std::array<uint32_t, 3>, uint32_t, KeyHash> first;
  first.reserve(mesh.vertices.size());
  std::vector<uint32_t> remap(mesh.vertices.size());
  std::vector<Vec3f> kept;
  kept.reserve(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    std::array<uint32_t, 3> key{};
    for (int k = 0; k < 3; ++k) key[k] = std::bit_cast<uint32_t>(mesh.vertices[i][k] + 0.0f);
    const auto [it, inserted] = first.try_emplace(key, static_cast<uint32_t>(kept.size()));
    if (inserted) kept.push_back(mesh.vertices[i]);
    remap[i] = it->second;
  }
  const std::size_t merged = mesh.vertices.size() - kept.size();
  mesh.vertices = std::move(kept);
  for (auto& t : mesh.triangles) {
    for (auto& v : t) v = remap[v];
  }
  return merged;
}

// Removes zero-area triangles. A sliver whose three corners are distinct (a "cap": one corner lies on
// the opposite edge) is fixed by splitting its neighbour across that edge at the corner, which keeps
// the surface closed; with no unique neighbour it is simply dropped.
std::size_t remove_degenerate(TriangleMesh& mesh) {
  auto& tris = mesh.triangles;
  std::vector<char> dead(tris.size(), 0);
  std::size_t removed = 0;

  // Triangles with a repeated index carry no area and no usable edge.
  std::vector<uint32_t> caps;
  for (uint32_t t = 0; t < tris.size(); ++t) {
    const auto& tri = tris[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
      dead[t] = 1;
      ++removed;
    } else if (zero_area(mesh, tri)) {
      caps.push_back(t);
    }
  }

  if (!caps.empty()) {
    // Edge -> triangles map over the live triangles, updated as neighbours are split.
    std::unordered_map<uint64_t, std::vector<uint32_t>> edge_tris;
    auto add_edges = [&](uint32_t t) {
      const auto& tri = tris[t];
      for (int k = 0; k < 3; ++k) edge_tris[edge_key(tri[k], tri[(k + 1) % 3])].push_back(t);
    };
    auto remove_edges = [&](uint32_t t) {
      const auto& tri = tris[t];
      for (int k = 0; k < 3; ++k) {
        auto& list = edge_tris[edge_key(tri[k], tri[(k + 1) % 3])];
        list.erase(std::remove(list.begin(), list.end(), t), list.end());
      }
    };
    for (uint32_t t = 0; t < tris.size(); ++t) {
      if (!dead[t]) add_edges(t);
    }

    // Splits may leave slivers to fix in turn (flat fans); a budget keeps that finite, after which
    // remaining slivers are only dropped.
    std::size_t split_budget = 2 * caps.size() + 16;
    for (std::size_t i = 0; i < caps.size(); ++i) {
      const uint32_t t = caps[i];
      if (dead[t]) continue;
      const Triangle cap = tris[t];
      // The longest edge (p, q) and the corner r lying on it.
      int longest = 0;
      double best = -1.0;
      for (int k = 0; k < 3; ++k) {
        const double len2 = (position(mesh, cap[(k + 1) % 3]) - position(mesh, cap[k])).squaredNorm();
        if (len2 > best) {
          best = len2;
          longest = k;
        }
      }
      const uint32_t p = cap[longest];
      const uint32_t q = cap[(longest + 1) % 3];
      const uint32_t r = cap[(longest + 2) % 3];
      remove_edges(t);
      dead[t] = 1;
      ++removed;

      // Split the unique neighbour (u, v, s) across {p, q} into (u, r, s) and (r, v, s).
      const auto& across = edge_tris[edge_key(p, q)];
      if (across.size() != 1 || split_budget == 0) continue;
      --split_budget;
      const uint32_t n = across.front();
      Triangle tri = tris[n];
      while (!((tri[0] == p && tri[1] == q) || (tri[0] == q && tri[1] == p))) {
        std::rotate(tri.begin(), tri.begin() + 1, tri.end());
      }
      const uint32_t u = tri[0];
      const uint32_t v = tri[1];
      const uint32_t s = tri[2];
      if (s == r) continue;
      remove_edges(n);
      tris[n] = {u, r, s};
      add_edges(n);
      const auto m = static_cast<uint32_t>(tris.size());
      tris.push_back({r, v, s});
      dead.push_back(0);
      add_edges(m);
      // The halves may themselves be slivers; queue them.
      if (zero_area(mesh, tris[n])) caps.push_back(n);
      if (zero_area(mesh, tris[m])) caps.push_back(m);
    }
  }

  std::size_t out = 0;
  for (std::size_t t = 0; t < tris.size(); ++t) {
    if (!dead[t]) tris[out++] = tris[t];
  }
  tris.resize(out);
  return removed;
}

// Removes repeated triangles (same three vertices in any order), keeping the first.
std::size_t remove_duplicate_triangles(TriangleMesh& mesh) {
  struct KeyHash {
    std::size_t operator()(const Triangle& k) const {
      return (std::size_t{k[0]} * 0x9E3779B97F4A7C15ull) ^ (std::size_t{k[1]} * 0xC2B2AE3D27D4EB4Full) ^
             (std::size_t{k[2]} * 0x165667B19E3779F9ull);
    }
  };
  std::unordered_set<Triangle, KeyHash> seen;
  seen.reserve(mesh.triangles.size());
  std::size_t out = 0;
  for (const auto& t : mesh.triangles) {
    Triangle key = t;
    std::sort(key.begin(), key.end());
    if (seen.insert(key).second) mesh.triangles[out++] = t;
  }
  const std::size_t removed = mesh.triangles.size() - out;
  mesh.triangles.resize(out);
  return removed;
}

// Undirected edges with the triangles using them, grouped by edge.
struct EdgeTable {
  struct Use {
    uint64_t key;
    uint32_t tri;
  };
  std::vector<Use> uses;  ///< sorted by key, then triangle

  explicit EdgeTable(const std::vector<Triangle>& tris) {
    uses.reserve(tris.size() * 3);
    for (uint32_t t = 0; t < tris.size(); ++t) {
      for (int k = 0; k < 3; ++k) uses.push_back({edge_key(tris[t][k], tris[t][(k + 1) % 3]), t});
    }
    std::sort(uses.begin(), uses.end(),
              [](const Use& a, const Use& b) { return a.key != b.key ? a.key < b.key : a.tri < b.tri; });
  }

  // Calls fn(first, count) for each group of uses sharing an edge.
  template <typename Fn>
  void for_each_edge(Fn&& fn) const {
    std::size_t i = 0;
    while (i < uses.size()) {
      std::size_t j = i + 1;
      while (j < uses.size() && uses[j].key == uses[i].key) ++j;
      fn(i, j - i);
      i = j;
    }
  }
};

// True when triangle t walks the edge from a to b.
bool walks(const Triangle& t, uint32_t a, uint32_t b) {
  return (t[0] == a && t[1] == b) || (t[1] == a && t[2] == b) || (t[2] == a && t[0] == b);
}

void flip(Triangle& t) { std::swap(t[1], t[2]); }

struct Orientation {
  std::vector<uint32_t> component;  ///< per triangle
  std::size_t components = 0;
  std::size_t conflicts = 0;  ///< manifold edges whose two triangles could not be made to agree
};

// Makes neighbouring triangles agree on winding (breadth-first over manifold edges, flipping where a
// shared edge is walked the same way by both); labels connected components.
Orientation orient_consistently(std::vector<Triangle>& tris, std::vector<char>& turned) {
  const EdgeTable table(tris);
  // Neighbour across each corner edge, or -1 when the edge is open or non-manifold.
  std::vector<std::array<int64_t, 3>> across(tris.size(), {-1, -1, -1});
  table.for_each_edge([&](std::size_t first, std::size_t count) {
    if (count != 2) return;
    const uint32_t t0 = table.uses[first].tri;
    const uint32_t t1 = table.uses[first + 1].tri;
    const uint64_t key = table.uses[first].key;
    for (const auto& [t, other] : {std::pair{t0, t1}, std::pair{t1, t0}}) {
      for (int k = 0; k < 3; ++k) {
        if (edge_key(tris[t][k], tris[t][(k + 1) % 3]) == key) across[t][k] = other;
      }
    }
  });

  Orientation out;
  constexpr uint32_t kUnvisited = ~uint32_t{0};
  out.component.assign(tris.size(), kUnvisited);
  std::vector<uint32_t> queue;
  for (uint32_t seed = 0; seed < tris.size(); ++seed) {
    if (out.component[seed] != kUnvisited) continue;
    const auto label = static_cast<uint32_t>(out.components++);
    out.component[seed] = label;
    queue.assign(1, seed);
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const uint32_t t = queue[head];
      for (int k = 0; k < 3; ++k) {
        if (across[t][k] < 0) continue;
        const auto n = static_cast<uint32_t>(across[t][k]);
        const uint32_t a = tris[t][k];
        const uint32_t b = tris[t][(k + 1) % 3];
        // Consistent neighbours walk the shared edge in opposite directions.
        const bool same_direction = walks(tris[n], a, b);
        if (out.component[n] == kUnvisited) {
          if (same_direction) {
            flip(tris[n]);
            turned[n] ^= 1;
          }
          out.component[n] = label;
          queue.push_back(n);
        } else if (same_direction) {
          ++out.conflicts;
        }
      }
    }
  }
  // Each conflicting edge was seen from both sides.
  out.conflicts /= 2;
  return out;
}

struct EdgeCounts {
  std::size_t boundary = 0;
  std::size_t nonmanifold = 0;
};

EdgeCounts count_edges(const std::vector<Triangle>& tris) {
  EdgeCounts counts;
  const EdgeTable table(tris);
  table.for_each_edge([&](std::size_t, std::size_t count) {
    if (count == 1) ++counts.boundary;
    if (count > 2) ++counts.nonmanifold;
  });
  return counts;
}

// Closes boundary loops of at most kMaxFilledHoleEdges edges whose perimeter is small against the
// mesh: three edges get one triangle, longer loops a fan around their centroid. Loops are followed
// along the boundary half-edges, so the patch takes the winding of the surrounding triangles. Nothing
// is filled when the boundary is not a set of simple loops (a vertex with two outgoing open edges).
std::size_t fill_small_holes(TriangleMesh& mesh) {
  auto& tris = mesh.triangles;
  const EdgeTable table(tris);
  std::unordered_map<uint32_t, uint32_t> next;  // boundary half-edge u -> v
  bool simple = true;
  table.for_each_edge([&](std::size_t first, std::size_t count) {
    if (count != 1) return;
    const Triangle& t = tris[table.uses[first].tri];
    const auto a = static_cast<uint32_t>(table.uses[first].key >> 32);
    const auto b = static_cast<uint32_t>(table.uses[first].key & 0xffffffffu);
    const auto [u, v] = walks(t, a, b) ? std::pair{a, b} : std::pair{b, a};
    if (!next.emplace(u, v).second) simple = false;
  });
  if (!simple || next.empty()) return 0;

  const double diagonal = mesh.bounds().diagonal().norm();
  std::unordered_set<uint32_t> visited;
  // Walk loops in vertex order so the result is deterministic.
  std::vector<uint32_t> starts;
  starts.reserve(next.size());
  for (const auto& [u, v] : next) starts.push_back(u);
  std::sort(starts.begin(), starts.end());

  std::size_t filled = 0;
  std::vector<uint32_t> loop;
  for (const uint32_t start : starts) {
    if (visited.count(start) != 0) continue;
    loop.clear();
    uint32_t u = start;
    bool closed = false;
    while (loop.size() <= kMaxFilledHoleEdges + 1) {
      loop.push_back(u);
      visited.insert(u);
      const auto it = next.find(u);
      if (it == next.end()) break;
      u = it->second;
      if (u == start) {
        closed = true;
        break;
      }
      if (visited.count(u) != 0) break;
    }
    if (!closed || loop.size() < 3 || loop.size() > kMaxFilledHoleEdges) {
      // Mark the rest of a long loop so it is not walked again from another vertex.
      while (visited.insert(u).second) {
        const auto it = next.find(u);
        if (it == next.end()) break;
        u = it->second;
      }
      continue;
    }
    double perimeter = 0.0;
    Vec3 centroid = Vec3::Zero();
    for (std::size_t i = 0; i < loop.size(); ++i) {
      perimeter += (position(mesh, loop[(i + 1) % loop.size()]) - position(mesh, loop[i])).norm();
      centroid += position(mesh, loop[i]);
    }
    centroid /= static_cast<double>(loop.size());
    if (perimeter > kMaxHolePerimeterFraction * diagonal) continue;

    // Patch triangles walk each loop edge backwards: (u_{i+1} -> u_i).
    std::vector<Triangle> patch;
    if (loop.size() == 3) {
      patch.push_back({loop[0], loop[2], loop[1]});
    } else {
      const auto c = static_cast<uint32_t>(mesh.vertices.size());
      mesh.vertices.push_back(centroid.cast<float>());
      for (std::size_t i = 0; i < loop.size(); ++i)
        patch.push_back({c, loop[(i + 1) % loop.size()], loop[i]});
    }
    bool ok = true;
    for (const auto& t : patch) ok = ok && !zero_area(mesh, t);
    if (!ok) {
      if (loop.size() != 3) mesh.vertices.pop_back();
      continue;
    }
    tris.insert(tris.end(), patch.begin(), patch.end());
    ++filled;
  }
  return filled;
}

// Signed volume (mm^3) of the triangles of one component, relative to a point of it for precision.
double component_volume(const TriangleMesh& mesh, const std::vector<uint32_t>& component, uint32_t label) {
  double six_volume = 0.0;
  bool have_origin = false;
  Vec3 origin = Vec3::Zero();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (component[t] != label) continue;
    const auto& tri = mesh.triangles[t];
    if (!have_origin) {
      origin = position(mesh, tri[0]);
      have_origin = true;
    }
    const Vec3 a = position(mesh, tri[0]) - origin;
    const Vec3 b = position(mesh, tri[1]) - origin;
    const Vec3 c = position(mesh, tri[2]) - origin;
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

// Drops vertices no triangle uses, keeping the order of the others.
std::size_t compact_vertices(TriangleMesh& mesh) {
  constexpr uint32_t kUnused = ~uint32_t{0};
  std::vector<uint32_t> remap(mesh.vertices.size(), kUnused);
  for (const auto& t : mesh.triangles) {
    for (const uint32_t v : t) remap[v] = 0;
  }
  uint32_t next = 0;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (remap[i] == kUnused) continue;
    remap[i] = next;
    mesh.vertices[next++] = mesh.vertices[i];
  }
  const std::size_t dropped = mesh.vertices.size() - next;
  mesh.vertices.resize(next);
  for (auto& t : mesh.triangles) {
    for (auto& v : t) v = remap[v];
  }
  return dropped;
}

}  // namespace

Eigen::AlignedBox3d TriangleMesh::bounds() const {
  Eigen::AlignedBox3d box(Vec3::Zero(), Vec3::Zero());
  if (vertices.empty()) return box;
  box.setEmpty();
  for (const auto& v : vertices) box.extend(v.cast<double>());
  return box;
}

void TriangleMesh::transform(const Pose& pose) {
  for (auto& v : vertices) v = pose.transform(v.cast<double>()).cast<float>();
}

double TriangleMesh::volume() const {
  if (vertices.empty()) return 0.0;
  // Sum of signed tetrahedra against the first vertex (translation-invariant for closed meshes).
  const Vec3 origin = vertices.front().cast<double>();
  double six_volume = 0.0;
  for (const auto& t : triangles) {
    const Vec3 a = vertices[t[0]].cast<double>() - origin;
    const Vec3 b = vertices[t[1]].cast<double>() - origin;
    const Vec3 c = vertices[t[2]].cast<double>() - origin;
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

double TriangleMesh::area() const {
  double twice = 0.0;
  for (const auto& t : triangles) {
    const Vec3 a = vertices[t[0]].cast<double>();
    twice += (vertices[t[1]].cast<double>() - a).cross(vertices[t[2]].cast<double>() - a).norm();
  }
  return 0.5 * twice;
}

namespace detail {

void validate_into(TriangleMesh& mesh, const std::string& what, MeshReport& report,
                   const MeshLoadOptions& options) {
  report.input_triangles += mesh.triangles.size();

  // Indices must point at vertices.
  const std::size_t n_vertices = mesh.vertices.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (const uint32_t v : mesh.triangles[t]) {
      if (v >= n_vertices) {
        fail(what,
             fmt::format("triangle {} refers to vertex {} but there are only {} vertices", t, v, n_vertices));
      }
    }
  }

  // Every used coordinate must be finite; name the vertex and a triangle using it.
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (const uint32_t v : mesh.triangles[t]) {
      const Vec3f& p = mesh.vertices[v];
      if (!p.allFinite()) {
        fail(what,
             fmt::format("non-finite coordinate (NaN or infinity) at vertex {} of triangle {}: ({}, {}, {})",
                         v, t, p.x(), p.y(), p.z()));
      }
    }
  }
  if (mesh.triangles.empty()) fail(what, "no triangles");

  // Weld coincident vertices.
  const std::size_t merged = weld_vertices(mesh);
  report.duplicates_merged += merged;
  if (merged > 0) report.warnings.push_back(fmt::format("welded {} duplicate vertices", merged));

  // Drop zero-area triangles (splitting neighbours of caps so the surface stays closed).
  const std::size_t before = mesh.triangles.size();
  const std::size_t degenerate = remove_degenerate(mesh);
  report.degenerate_removed += degenerate;
  if (mesh.triangles.empty()) fail(what, fmt::format("all {} triangles are degenerate (zero area)", before));
  if (degenerate > 0) report.warnings.push_back(fmt::format("removed {} degenerate triangles", degenerate));

  // Drop repeated triangles.
  const std::size_t repeated = remove_duplicate_triangles(mesh);
  if (repeated > 0) report.warnings.push_back(fmt::format("removed {} repeated triangles", repeated));

  // Consistent winding across neighbours, then small holes closed with that winding.
  std::vector<char> turned(mesh.triangles.size(), 0);
  Orientation orientation = orient_consistently(mesh.triangles, turned);
  if (options.fill_small_holes) {
    const std::size_t filled = fill_small_holes(mesh);
    if (filled > 0) {
      report.holes_filled += filled;
      report.warnings.push_back(fmt::format("closed {} small holes", filled));
      turned.resize(mesh.triangles.size(), 0);
      orientation = orient_consistently(mesh.triangles, turned);
    }
  }

  // Each closed shell faces outward: positive signed volume.
  std::vector<char> component_flipped(orientation.components, 0);
  for (uint32_t c = 0; c < orientation.components; ++c) {
    component_flipped[c] = component_volume(mesh, orientation.component, c) < 0.0;
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (component_flipped[orientation.component[t]]) {
      flip(mesh.triangles[t]);
      turned[t] ^= 1;
      report.flipped = true;
    }
  }
  const auto reoriented = static_cast<std::size_t>(std::count(turned.begin(), turned.end(), 1));
  report.reoriented += reoriented;
  if (report.flipped) report.warnings.push_back("reversed the winding so that normals face outward");
  if (reoriented > 0) report.warnings.push_back(fmt::format("re-oriented {} triangles", reoriented));
  report.components = orientation.components;
  if (orientation.components > 1) {
    report.warnings.push_back(fmt::format("{} separate shells", orientation.components));
  }

  // What repair could not fix.
  const EdgeCounts edges = count_edges(mesh.triangles);
  report.boundary_edges = edges.boundary;
  report.nonmanifold_edges = edges.nonmanifold;
  if (options.require_closed) {
    if (edges.nonmanifold > 0) {
      fail(what, fmt::format("non-manifold mesh: {} edges are shared by more than two triangles",
                             edges.nonmanifold));
    }
    if (edges.boundary > 0) {
      fail(what, fmt::format("open mesh: {} boundary edges (holes) remain after repair", edges.boundary));
    }
    if (orientation.conflicts > 0) {
      fail(what, fmt::format("non-orientable mesh: {} edges cannot be given a consistent winding",
                             orientation.conflicts));
    }
    if (!(mesh.volume() > kMinVolumeFraction * std::pow(mesh.bounds().diagonal().norm(), 3))) {
      fail(what, fmt::format(
                     "degenerate solid: the closed surface encloses no volume ({:.3g} mm^3; flat or folded)",
                     mesh.volume()));
    }
  } else {
    if (edges.boundary > 0)
      report.warnings.push_back(fmt::format("open mesh: {} boundary edges", edges.boundary));
    if (edges.nonmanifold > 0) {
      report.warnings.push_back(fmt::format("non-manifold mesh: {} edges", edges.nonmanifold));
    }
    if (orientation.conflicts > 0) {
      report.warnings.push_back(fmt::format("non-orientable mesh: {} edges", orientation.conflicts));
    }
  }

  // Unused vertices go; units are checked for plausibility (teeth are millimetres across): a size no
  // scene can hold (a scan in metres read as mm is a kilometre; in micrometres, a speck the trees
  // cannot resolve) is an error that says so, instead of a tree that fails later with another story.
  compact_vertices(mesh);
  const double extent = mesh.bounds().sizes().maxCoeff();
  if (!(extent >= kMinMeshExtent && extent <= kMaxMeshExtent)) {
    fail(what,
         fmt::format("largest extent is {:.4g} mm, outside [{:g}, {:g}] mm: the file is probably not in "
                     "millimetres; give the object a `scale` (e.g. 1000 for metres, 0.001 for micrometres)",
                     extent, kMinMeshExtent, kMaxMeshExtent));
  }
  if (extent < 0.5) {
    report.warnings.push_back(
        fmt::format("largest extent is {:.4g} mm: check the units (expected mm)", extent));
  }

  // A surface that crosses itself has no clear inside: the signed distance, and with it the tree,
  // pokes out where the sheets cross (2.2 mm on a crossed-sheet example). A closed solid is refused
  // (cariesim does not repair it: which sheet is right is a modelling decision); elsewhere it is a
  // warning.
  if (options.check_self_intersections) {
    report.self_intersections = count_self_intersections(mesh);
    if (report.self_intersections > 0 && options.require_closed) {
      fail(what,
           fmt::format("the surface intersects itself ({} pairs of triangles cross): its inside is "
                       "ambiguous and the sphere tree would poke out where the sheets cross; repair the "
                       "mesh (e.g. remove self-intersections in MeshLab) and load it again",
                       report.self_intersections));
    }
    if (report.self_intersections > 0) {
      report.warnings.push_back(
          fmt::format("{} pairs of triangles intersect each other", report.self_intersections));
    }
  }

  // A closed shell inside another: a hollow solid (a surface around an inner cavity) or a part
  // within a part. Level sets and sphere trees fill every closed shell, so the cavity would silently
  // become solid: refused, naming the shells.
  if (options.require_closed && orientation.components > 1 && report.self_intersections == 0) {
    const NestedShells nested =
        find_nested_shell(mesh, orientation.component, orientation.components, kMaxNestingWork);
    if (nested.too_costly) {
      fail(what, fmt::format("{} separate shells lie within one another's bounds, too many to check that "
                             "none is inside another; give each part its own file",
                             orientation.components));
    }
    if (nested.found) {
      fail(what,
           fmt::format("shell {} ({} triangles) lies inside shell {} ({} triangles): a hollow solid "
                       "(an inner cavity) or a part inside another; sphere trees fill every closed "
                       "shell, so the cavity would become solid: remove the inner shell, or give "
                       "each part its own object",
                       nested.inner + 1, nested.inner_triangles, nested.outer + 1, nested.outer_triangles));
    }
  }
}

}  // namespace detail

void validate_mesh(TriangleMesh& mesh, const std::string& what, MeshReport* report,
                   const MeshLoadOptions& options) {
  MeshReport local;
  detail::validate_into(mesh, what, local, options);
  if (report != nullptr) *report = std::move(local);
}

void save_stl(const TriangleMesh& mesh, const std::filesystem::path& file) {
  const std::string what = file.string();
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) fail(what, "cannot open the file for writing");

  // Little-endian fields of the binary STL layout.
  auto put_u32 = [&](uint32_t v) {
    const std::array<char, 4> bytes{static_cast<char>(v & 0xff), static_cast<char>((v >> 8) & 0xff),
                                    static_cast<char>((v >> 16) & 0xff), static_cast<char>((v >> 24) & 0xff)};
    out.write(bytes.data(), bytes.size());
  };
  auto put_vec = [&](const Vec3f& v) {
    for (int k = 0; k < 3; ++k) put_u32(std::bit_cast<uint32_t>(v[k]));
  };

  // 80-byte header (must not start with "solid"), triangle count, then 50 bytes per triangle.
  std::array<char, 80> header{};
  const std::string title = "cariesim binary STL, millimetres";
  std::memcpy(header.data(), title.data(), title.size());
  out.write(header.data(), header.size());
  put_u32(static_cast<uint32_t>(mesh.triangles.size()));
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]].cast<double>();
    const Vec3 n = (mesh.vertices[t[1]].cast<double>() - a).cross(mesh.vertices[t[2]].cast<double>() - a);
    const double len = n.norm();
    put_vec(len > 0.0 ? Vec3f((n / len).cast<float>()) : Vec3f::Zero());
    for (const uint32_t v : t) put_vec(mesh.vertices[v]);
    out.write("\0\0", 2);
  }
  out.flush();
  if (!out) fail(what, "write failed");
}

}  // namespace cariesim
