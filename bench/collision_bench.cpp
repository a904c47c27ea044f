// Collision benchmark: the dental explorer against a real lower molar, ours against FCL 0.7.
//
// The query (what the haptic step asks every cycle, docs/design.md §4 step 1): every pair of a tool
// sphere and the tooth closer than a margin (0.1 mm, about one sub-step of tool motion), with the
// gap/normal/point of each pair. Timed per query, including moving the tool to the new pose.
//
// Ours: `PlacedTool::place` + `collide` of the explorer's sphere tree against the molar's sphere tree
// (the tight tree: leaf spheres inscribed under the scanned surface), into a ContactSet of capacity 1024,
// then `contact_geometry` of every pair (collide reports ids and gaps; normal and point are computed
// on demand, and are here so that both sides give the same answer).
//
// FCL 0.7 (Debian libfcl-dev), the same tooth as FCL's native representation of a scan: a
// BVHModel<OBBRSS> of the triangle mesh (the best BV type FCL offers for mesh collision). The tool is
// the same sphere chain, each sphere an fcl::Sphere whose radius is inflated by the margin, so that
// "overlaps the inflated sphere" is exactly "closer than the margin"; collide() with contacts
// enabled and num_max_contacts = 1024 then enumerates every (tool sphere, triangle) pair within the
// margin with its normal, position and depth: the same information as our contact set. FCL has no
// "all pairs within d" distance query (distance() returns one closest pair per object pair), so
// collision on inflated spheres is the fair equivalent. Two FCL set-ups are timed and the faster one
// is FCL's number: (a) a DynamicAABBTree broadphase manager over the tool spheres, updated with the
// new pose, colliding against the tooth object; (b) a plain loop of collide(sphere_i, tooth) over
// all tool spheres. Both count the per-query transform update, as ours counts place().
//
// Why this is a fair comparison: the same tool chain, the same tooth scan, the same margin, the same
// poses, the same answer (all pairs within the margin with normal, point and depth), each library
// with its own representation of the tooth built once outside the timed region, and both sides pay
// for moving the tool every query. The representations differ by design (that choice is what is
// being compared): FCL's mesh is the exact scan (45k triangles, sphere-triangle tests), ours ~22k
// sphere leaves (sphere-sphere tests). FCL's contact count is per triangle, ours per leaf sphere, so
// the counts differ somewhat for the same contact region. FCL's CollisionResult is cleared and
// reused (its vector keeps its capacity); ours writes into a preallocated ContactSet.
// The molar's tree is the tight tree (build_sphere_tree, default parameters). The explorer is
// make_explorer_spheres() with its defaults (173 spheres, tip radius 0.05 mm).
//
// Scenarios: the tip resting on the occlusal surface with the shank clear (sliding); the tip down in
// the central fossa (fissure: several walls at once); the tool 1 mm above the tooth (free space
// near the tooth: no contact, but the trees come close). Each timed query moves the tool along a
// small precomputed path (a few tens of micrometres) around the scenario's pose, as sliding does.
//
// Run: build/bench/collision_bench --benchmark_counters_tabular=true
// Counters: p50_us / p99_us per query (from our own clock around each query), contacts per query.
// The scan is the shipped data/open-full-jaw/patient26/tooth_30.ply; without it the program says so
// and skips (exit status 0); a file that cannot be read is reported (exit status 1), never an abort.

#include <benchmark/benchmark.h>
#include <fcl/fcl.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "cariesim/collision/collide.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/level_set.hpp"

namespace {

using cariesim::Vec3;
using cariesim::Vec3f;

constexpr double kMargin = 0.1;          // mm, per tool leaf
constexpr std::size_t kCapacity = 1024;  // contacts per query, both sides
constexpr double kRestingGap = -0.005;   // mm, the tip's gap when it rests on the surface
constexpr int kPathLength = 1024;        // poses along each scenario's small path

const std::filesystem::path kDataDir = CARIESIM_DATA_DIR "/open-full-jaw/patient26";
const std::filesystem::path kToothFile = kDataDir / "tooth_30.ply";
const std::filesystem::path kAxesFile = kDataDir / "teeth_axes_mandible.json";

// The scanned molar: the mesh, its vertices (mm) and triangles for FCL.
struct Tooth {
  cariesim::TriangleMesh mesh;
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 3>> triangles;
  Vec3 axis;    // unit, occlusal direction (tooth long axis from teeth_axes_mandible.json)
  Vec3 centre;  // mm, the tooth's centre from the same file
};

// Loads tooth_30 (FDI 46) with load_mesh (welded, oriented outward) and its axis from the JSON
// file (read with yaml-cpp: JSON is YAML).
Tooth load_tooth() {
  Tooth tooth;
  tooth.mesh = cariesim::load_mesh(kToothFile);
  for (const Vec3f& v : tooth.mesh.vertices) tooth.vertices.push_back(v.cast<double>());
  for (const auto& t : tooth.mesh.triangles) {
    tooth.triangles.push_back({static_cast<int>(t[0]), static_cast<int>(t[1]), static_cast<int>(t[2])});
  }
  const YAML::Node axes = YAML::LoadFile(kAxesFile.string())["30"];
  if (!axes.IsMap()) throw cariesim::Error(kAxesFile.string() + ": no axes for tooth 30");
  Vec3 c;
  Vec3 z;
  for (int k = 0; k < 3; ++k) {
    c[k] = axes["c"][k].as<double>();
    z[k] = axes["z"][k].as<double>();
  }
  tooth.centre = c;
  tooth.axis = (z - c).normalized();
  return tooth;
}

// The molar's tight sphere tree (default TreeParams: inscribed leaves within 0.015 mm of the
// surface, 4-ary hierarchy), as the simulator builds it.
cariesim::SphereTree tooth_tree(const Tooth& tooth) {
  const cariesim::TreeParams params;
  const cariesim::LevelSetResolution res = cariesim::choose_resolution(tooth.mesh, params);
  return cariesim::build_sphere_tree(cariesim::LevelSet::from_mesh(tooth.mesh, res.voxel, res.half_band),
                                     params);
}

// Tool orientation: +z (toward the handle) along the tooth axis, tilted 20 degrees about an axis
// across the tooth, as a hand holds the explorer over an occlusal surface.
cariesim::Quat tool_orientation(const Tooth& tooth) {
  const cariesim::Quat up = cariesim::Quat::FromTwoVectors(Vec3::UnitZ(), tooth.axis);
  const Vec3 side = tooth.axis.unitOrthogonal();
  return cariesim::Quat(Eigen::AngleAxisd(20.0 * std::numbers::pi / 180.0, side)) * up;
}

// Everything both engines need, built once.
struct World {
  Tooth tooth;
  std::vector<cariesim::ToolSphere> chain;
  cariesim::SphereTree tool_tree;
  std::vector<cariesim::CollisionObject> objects;
  std::array<std::vector<cariesim::Pose>, 3> paths;  // per scenario
  std::array<const char*, 3> names{"sliding", "fissure", "free"};
};

// Height (mm, along the tooth axis above `surface_point`) at which the tip's smallest gap to the
// tooth is `target`; bisection on the closest-pair query.
double resting_height(const World& w, cariesim::PlacedTool& placed, const Vec3& surface_point,
                      const cariesim::Quat& q, double target) {
  double lo = -2.0;
  double hi = 6.0;
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    cariesim::Pose pose{surface_point + w.tooth.axis * mid, q};
    placed.place(pose, 0.0);
    const double gap = cariesim::closest(placed, w.objects, cariesim::kAllObjects, 10.0).gap;
    (gap > target ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

// Widest angle (rad) between the normals of the pairs within 0.01 mm of the tool at `pose`.
double normal_spread(const World& w, cariesim::PlacedTool& placed, const cariesim::Pose& pose) {
  static cariesim::ContactSet probe(kCapacity);
  placed.place(pose, 0.01);
  probe.clear();
  cariesim::collide(placed, w.objects, cariesim::kAllObjects, probe);
  double spread = 0.0;
  for (const cariesim::Contact& a : probe.view()) {
    const Vec3 n_a = cariesim::contact_geometry(placed, w.objects, a).normal;
    for (const cariesim::Contact& b : probe.view()) {
      const Vec3 n_b = cariesim::contact_geometry(placed, w.objects, b).normal;
      spread = std::max(spread, std::acos(std::clamp(n_a.dot(n_b), -1.0, 1.0)));
    }
  }
  return spread;
}

// A small closed path around `centre` in the plane normal to the axis (radius 0.03 mm).
std::vector<cariesim::Pose> path_around(const World& w, const cariesim::Pose& centre) {
  const Vec3 u = w.tooth.axis.unitOrthogonal();
  const Vec3 v = w.tooth.axis.cross(u);
  std::vector<cariesim::Pose> path;
  for (int i = 0; i < kPathLength; ++i) {
    const double a = 2.0 * std::numbers::pi * i / kPathLength;
    path.push_back({centre.p + 0.03 * (std::cos(a) * u + std::sin(a) * v), centre.q});
  }
  return path;
}

const World& world() {
  static const World w = [] {
    World w;
    w.tooth = load_tooth();
    cariesim::CollisionObject obj;
    obj.name = "tooth46";
    obj.tree = tooth_tree(w.tooth);
    w.objects.push_back(std::move(obj));
    w.chain = cariesim::make_explorer_spheres();
    w.tool_tree = cariesim::build_tool_tree(w.chain, 4);
    cariesim::PlacedTool placed(w.tool_tree);
    const cariesim::Quat q = tool_orientation(w.tooth);
    // Sliding: the highest point of the crown (a cusp tip).
    Vec3 top = w.tooth.vertices[0];
    for (const Vec3& p : w.tooth.vertices) {
      if (p.dot(w.tooth.axis) > top.dot(w.tooth.axis)) top = p;
    }
    // Fissure: over a 0.1 mm grid within 3 mm of the tooth's axis, lower the tip along the axis until
    // it rests; keep the lowest rest whose contacts face each other (normals >= 60 degrees apart:
    // the tip wedged between two walls), else the widest spread.
    const Vec3 u = w.tooth.axis.unitOrthogonal();
    const Vec3 v = w.tooth.axis.cross(u);
    constexpr double kWedged = std::numbers::pi / 3.0;
    Vec3 fossa = w.tooth.centre;
    double h_fossa = 0.0;
    double best_spread = -1.0;
    for (double x = -3.0; x <= 3.0; x += 0.1) {
      for (double y = -3.0; y <= 3.0; y += 0.1) {
        if (x * x + y * y > 9.0) continue;
        const Vec3 base = w.tooth.centre + x * u + y * v;
        const double h = resting_height(w, placed, base, q, kRestingGap);
        const double spread = normal_spread(w, placed, {base + w.tooth.axis * h, q});
        const bool better = spread >= kWedged ? (best_spread < kWedged || h < h_fossa) : spread > best_spread;
        if (better) {
          fossa = base;
          h_fossa = h;
          best_spread = spread;
        }
      }
    }
    std::printf("fissure site: contact normals %.0f deg apart at rest\n",
                best_spread * 180.0 / std::numbers::pi);
    const double h_top = resting_height(w, placed, top, q, kRestingGap);
    w.paths[0] = path_around(w, {top + w.tooth.axis * h_top, q});
    w.paths[1] = path_around(w, {fossa + w.tooth.axis * h_fossa, q});
    w.paths[2] = path_around(w, {top + w.tooth.axis * (h_top + 1.0), q});
    // What each scenario touches: contacts per tool segment (tip, working end, shank, handle).
    cariesim::ContactSet probe(kCapacity);
    for (std::size_t k = 0; k < w.paths.size(); ++k) {
      placed.place(w.paths[k][0], kMargin);
      probe.clear();
      cariesim::collide(placed, w.objects, cariesim::kAllObjects, probe);
      std::array<int, 4> per_segment{};
      double min_gap = std::numeric_limits<double>::infinity();
      for (const cariesim::Contact& c : probe.view()) {
        ++per_segment[w.chain[c.tool_leaf].segment];
        min_gap = std::min(min_gap, c.gap);
      }
      const double spread = normal_spread(w, placed, w.paths[k][0]);
      std::printf(
          "%s: contacts tip %d, working end %d, shank %d, handle %d; smallest gap %.4f mm; normals within "
          "%.0f deg\n",
          w.names[k], per_segment[0], per_segment[1], per_segment[2], per_segment[3], min_gap,
          spread * 180.0 / std::numbers::pi);
    }
    std::printf("tooth: %zu vertices, %zu triangles; tree %zu leaves, %d levels; tool %zu spheres\n",
                w.tooth.vertices.size(), w.tooth.triangles.size(), w.objects[0].tree.leaf_count(),
                w.objects[0].tree.levels, w.chain.size());
    return w;
  }();
  return w;
}

// Per-query timing samples -> p50/p99 counters (microseconds).
struct Samples {
  std::vector<double> us;
  void report(benchmark::State& state, double contacts_per_query) {
    if (us.empty()) return;
    std::sort(us.begin(), us.end());
    state.counters["p50_us"] = us[us.size() / 2];
    state.counters["p99_us"] = us[std::min(us.size() - 1, us.size() * 99 / 100)];
    state.counters["contacts"] = contacts_per_query;
  }
};

using Clock = std::chrono::steady_clock;
double micros(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

// Ours: place the tool at the next pose of the path, collect every pair within the margin with its
// normal and point.
void BM_Ours(benchmark::State& state) {
  const World& w = world();
  const auto& path = w.paths[static_cast<std::size_t>(state.range(0))];
  state.SetLabel(w.names[static_cast<std::size_t>(state.range(0))]);
  cariesim::PlacedTool placed(w.tool_tree);
  cariesim::ContactSet contacts(kCapacity);
  Samples samples;
  samples.us.reserve(1 << 22);
  std::size_t i = 0;
  double total_contacts = 0.0;
  for (auto _ : state) {
    const cariesim::Pose& pose = path[i++ % path.size()];
    const Clock::time_point t0 = Clock::now();
    placed.place(pose, kMargin);
    contacts.clear();
    cariesim::collide(placed, w.objects, cariesim::kAllObjects, contacts);
    for (const cariesim::Contact& c : contacts.view()) {
      const cariesim::ContactGeometry geo = cariesim::contact_geometry(placed, w.objects, c);
      benchmark::DoNotOptimize(geo);
    }
    const Clock::time_point t1 = Clock::now();
    benchmark::DoNotOptimize(contacts.size());
    total_contacts += static_cast<double>(contacts.size());
    if (samples.us.size() < samples.us.capacity()) samples.us.push_back(micros(t0, t1));
  }
  samples.report(state, total_contacts / static_cast<double>(std::max<std::size_t>(i, 1)));
}

// Ours, the two halves apart: place() alone, and collide() alone at a fixed placement.
void BM_OursPlaceOnly(benchmark::State& state) {
  const World& w = world();
  cariesim::PlacedTool placed(w.tool_tree);
  std::size_t i = 0;
  for (auto _ : state) {
    placed.place(w.paths[0][i++ % kPathLength], kMargin);
    benchmark::DoNotOptimize(placed.radii().data());
  }
}

void BM_OursCollideOnly(benchmark::State& state) {
  const World& w = world();
  state.SetLabel(w.names[static_cast<std::size_t>(state.range(0))]);
  cariesim::PlacedTool placed(w.tool_tree);
  placed.place(w.paths[static_cast<std::size_t>(state.range(0))][0], kMargin);
  cariesim::ContactSet contacts(kCapacity);
  for (auto _ : state) {
    contacts.clear();
    cariesim::collide(placed, w.objects, cariesim::kAllObjects, contacts);
    benchmark::DoNotOptimize(contacts.size());
  }
}

// FCL's side of the world: the mesh BVH and one sphere object per tool sphere (inflated radius).
struct FclWorld {
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> mesh;
  std::unique_ptr<fcl::CollisionObjectd> tooth;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> spheres;
  std::vector<Vec3> local;  // tool-frame sphere centres
};

std::unique_ptr<FclWorld> make_fcl(const World& w) {
  auto f = std::make_unique<FclWorld>();
  f->mesh = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  std::vector<fcl::Vector3d> points(w.tooth.vertices.begin(), w.tooth.vertices.end());
  std::vector<fcl::Triangle> tris;
  for (const auto& t : w.tooth.triangles) tris.emplace_back(t[0], t[1], t[2]);
  f->mesh->beginModel(static_cast<int>(tris.size()), static_cast<int>(points.size()));
  f->mesh->addSubModel(points, tris);
  f->mesh->endModel();
  f->tooth = std::make_unique<fcl::CollisionObjectd>(f->mesh, fcl::Transform3d::Identity());
  for (const cariesim::ToolSphere& s : w.chain) {
    auto geom = std::make_shared<fcl::Sphered>(s.radius + kMargin);
    f->spheres.push_back(std::make_unique<fcl::CollisionObjectd>(geom, fcl::Transform3d::Identity()));
    f->local.push_back(s.center);
  }
  return f;
}

// Moves every FCL tool sphere to the pose (and refreshes its AABB).
void place_fcl(FclWorld& f, const cariesim::Pose& pose) {
  const cariesim::Mat3 r = pose.q.toRotationMatrix();
  for (std::size_t k = 0; k < f.spheres.size(); ++k) {
    f.spheres[k]->setTranslation(pose.p + r * f.local[k]);
    f.spheres[k]->computeAABB();
  }
}

struct FclQuery {
  fcl::CollisionRequestd request;
  fcl::CollisionResultd result;
  std::size_t contacts = 0;
};

// Broadphase callback: narrow phase of one (tool sphere, tooth) pair, contacts accumulated.
bool fcl_pair(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
  auto* q = static_cast<FclQuery*>(data);
  q->result.clear();
  fcl::collide(a, b, q->request, q->result);
  q->contacts += q->result.numContacts();
  return false;
}

fcl::CollisionRequestd fcl_request(bool indep) {
  fcl::CollisionRequestd request(kCapacity, true);
  request.gjk_solver_type = indep ? fcl::GST_INDEP : fcl::GST_LIBCCD;
  return request;
}

// FCL (a): a dynamic AABB tree over the tool spheres, updated per query, against the tooth.
void BM_FclBroadphase(benchmark::State& state) {
  const World& w = world();
  const auto& path = w.paths[static_cast<std::size_t>(state.range(0))];
  state.SetLabel(std::string(w.names[static_cast<std::size_t>(state.range(0))]) +
                 (state.range(1) != 0 ? " indep" : " libccd"));
  auto f = make_fcl(w);
  fcl::DynamicAABBTreeCollisionManagerd manager;
  std::vector<fcl::CollisionObjectd*> objs;
  for (auto& s : f->spheres) objs.push_back(s.get());
  place_fcl(*f, path[0]);
  manager.registerObjects(objs);
  manager.setup();
  FclQuery q;
  q.request = fcl_request(state.range(1) != 0);
  Samples samples;
  samples.us.reserve(1 << 22);
  std::size_t i = 0;
  double total_contacts = 0.0;
  for (auto _ : state) {
    const cariesim::Pose& pose = path[i++ % path.size()];
    const Clock::time_point t0 = Clock::now();
    place_fcl(*f, pose);
    manager.update();
    q.contacts = 0;
    manager.collide(f->tooth.get(), &q, fcl_pair);
    const Clock::time_point t1 = Clock::now();
    total_contacts += static_cast<double>(q.contacts);
    if (samples.us.size() < samples.us.capacity()) samples.us.push_back(micros(t0, t1));
  }
  samples.report(state, total_contacts / static_cast<double>(std::max<std::size_t>(i, 1)));
}

// FCL (b): collide() of every tool sphere against the tooth, no broadphase.
void BM_FclLoop(benchmark::State& state) {
  const World& w = world();
  const auto& path = w.paths[static_cast<std::size_t>(state.range(0))];
  state.SetLabel(std::string(w.names[static_cast<std::size_t>(state.range(0))]) +
                 (state.range(1) != 0 ? " indep" : " libccd"));
  auto f = make_fcl(w);
  FclQuery q;
  q.request = fcl_request(state.range(1) != 0);
  Samples samples;
  samples.us.reserve(1 << 22);
  std::size_t i = 0;
  double total_contacts = 0.0;
  for (auto _ : state) {
    const cariesim::Pose& pose = path[i++ % path.size()];
    const Clock::time_point t0 = Clock::now();
    const cariesim::Mat3 r = pose.q.toRotationMatrix();
    q.contacts = 0;
    for (std::size_t k = 0; k < f->spheres.size(); ++k) {
      f->spheres[k]->setTranslation(pose.p + r * f->local[k]);
      q.result.clear();
      fcl::collide(f->spheres[k].get(), f->tooth.get(), q.request, q.result);
      q.contacts += q.result.numContacts();
    }
    const Clock::time_point t1 = Clock::now();
    total_contacts += static_cast<double>(q.contacts);
    if (samples.us.size() < samples.us.capacity()) samples.us.push_back(micros(t0, t1));
  }
  samples.report(state, total_contacts / static_cast<double>(std::max<std::size_t>(i, 1)));
}

BENCHMARK(BM_Ours)->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_OursPlaceOnly)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_OursCollideOnly)->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FclBroadphase)->ArgsProduct({{0, 1, 2}, {0, 1}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FclLoop)->ArgsProduct({{0, 1, 2}, {0, 1}})->Unit(benchmark::kMicrosecond);

}  // namespace

// Google Benchmark's main, after checking the scan: a missing file skips the benchmark with a
// message, a broken one is reported; both instead of an uncaught exception inside a benchmark.
int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const auto& file : {kToothFile, kAxesFile}) {
    if (!std::filesystem::is_regular_file(file)) {
      std::printf("collision_bench: skipped: the shipped scan is missing: %s\n", file.string().c_str());
      return 0;
    }
  }
  try {
    (void)world();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "collision_bench: cannot load the scan: %s\n", e.what());
    return 1;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
