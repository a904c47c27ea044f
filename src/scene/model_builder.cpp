// The model builder, build_model: SceneDesc -> Model (docs/design.md §3). Per object: mesh or procedural
// shape in the world, lesions placed (and snapped) on it, level sets, CSG (healthy = object - lesions,
// caries_i = object ∩ lesion_i; paper §2.2), one sphere tree per part (cached), leaf labels and
// materials. Then the tool, gains, limits, and a check that the model is usable.

#include "cariesim/scene/model_builder.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <optional>

#include "cariesim/collision/collide.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/nearest.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/geometry/ray_cast.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/cache.hpp"
#include "cariesim/spheretree/level_set.hpp"

namespace cariesim {
namespace {

// Level-set half band, in voxels (as spheretree's choose_resolution).
constexpr double kBandVoxels = 5.0;
// Height of the default tool home above the scene's highest point (mm).
constexpr double kHomeClearance = 10.0;

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// "file:line:column: objects 'name'" for messages about a scene entry.
std::string object_context(const ObjectDesc& o) {
  return fmt::format("{}: object '{}'", o.where.str(), o.name);
}
std::string lesion_context(const LesionDesc& l) {
  return fmt::format("{}: lesion '{}'", l.where.str(), l.name);
}

// The whole content of a mesh file (its bytes go into the cache key), bounded like load_mesh's read.
std::string file_bytes(const std::filesystem::path& file) {
  return io::read_file(file, "mesh", kMaxMeshFileBytes);
}

// An object's surface in its own frame: the mesh file or the procedural generator.
TriangleMesh object_mesh(const ObjectDesc& o) {
  try {
    switch (o.shape.kind) {
      case ShapeDesc::Kind::Mesh:
        return load_mesh(o.shape.file, nullptr, mesh_load_options(o.shape));
      case ShapeDesc::Kind::Cuboid:
        return make_cuboid(o.shape.size);
      case ShapeDesc::Kind::Molar:
        return make_molar(o.shape.molar);
      case ShapeDesc::Kind::Premolar:
        return make_premolar(o.shape.premolar);
      case ShapeDesc::Kind::Gingiva:
        return make_gingiva_band(o.shape.gingiva);
      case ShapeDesc::Kind::Tongue:
        return make_tongue(o.shape.tongue);
    }
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", object_context(o), e.what()));
  }
  throw Error(fmt::format("{}: unknown shape", object_context(o)));
}

// Display meshes use OpenVDB's adaptive meshing: 0.1 keeps the shape well within the trees' tolerance
// to the eye with ~30x fewer triangles than a uniform mesh (a molar: 24k instead of 697k).
constexpr double kDisplayAdaptivity = 0.1;

// A lesion in the world, its centre snapped onto the host's world surface along the normal.
LesionShape place_lesion(const SceneDesc& scene, const LesionDesc& l, const TriangleMesh& host_world) {
  LesionShape s = lesion_shape_in_world(scene, l);
  if (!l.snap) return s;
  std::optional<double> t;
  try {
    t = nearest_crossing(host_world, s.center, s.normal, l.snap_range);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", lesion_context(l), e.what()));
  }
  if (!t) {
    throw Error(
        fmt::format("{}: the line through placement.at along the normal does not meet the surface of '{}' "
                    "within snap_range {} mm",
                    lesion_context(l), scene.objects[static_cast<std::size_t>(l.object)].name, l.snap_range));
  }
  s.center += *t * s.normal;
  return s;
}

// Tree parameters of an object after the command-line overrides.
TreeParams effective_params(const ObjectDesc& o, const BuildOptions& options) {
  TreeParams p = o.tree.params;
  if (options.mode) p.mode = *options.mode;
  if (options.octree_depth) p.depth = *options.octree_depth;
  if (options.tolerance) p.tolerance = *options.tolerance;
  return p;
}

// The state of building one scene object's parts. The mesh, the resolution and the level sets are
// made on demand: a cache hit on every part of a lesion-free object needs none of them.
struct ObjectBuild {
  const ObjectDesc* desc = nullptr;
  TreeParams params;
  std::vector<int> lesions;               // indices into SceneDesc::lesions
  std::vector<LesionShape> shapes;        // their world shapes (snapped)
  std::optional<TriangleMesh> mesh;       // the object's surface in the world
  std::optional<LevelSetResolution> res;  // voxel and band of every level set of this object
  std::optional<LevelSet> object_ls;
  std::vector<LevelSet> lesion_ls;
  // Seam leaves per part ([0] healthy, [1 + k] the k-th lesion's caries), made with the first part.
  std::optional<std::vector<std::vector<LeafSphere>>> seam;

  // The object's surface in the world.
  const TriangleMesh& world_mesh() {
    if (!mesh) {
      mesh = object_mesh(*desc);
      mesh->transform(desc->pose);
    }
    return *mesh;
  }

  // The level-set resolution: the object's `voxel`, else chosen from its surface and tree mode.
  const LevelSetResolution& resolution() {
    if (!res) {
      if (desc->tree.voxel) {
        res = LevelSetResolution{*desc->tree.voxel, kBandVoxels * *desc->tree.voxel};
      } else {
        try {
          res = choose_resolution(world_mesh(), params);
        } catch (const Error& e) {
          throw Error(fmt::format("{}: {}", object_context(*desc), e.what()));
        }
      }
    }
    return *res;
  }
};

// Level sets of the object and its lesions (once).
void make_level_sets(ObjectBuild& b) {
  if (b.object_ls) return;
  try {
    const LevelSetResolution& res = b.resolution();
    b.object_ls = LevelSet::from_mesh(b.world_mesh(), res.voxel, res.half_band);
    for (const LesionShape& s : b.shapes) b.lesion_ls.push_back(s.to_level_set(res.voxel, res.half_band));
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", object_context(*b.desc), e.what()));
  }
}

// The level set of part `part` (-1 healthy, or the whole object without lesions; else the k-th lesion).
LevelSet part_level_set(ObjectBuild& b, int part) {
  make_level_sets(b);
  if (part < 0) {
    LevelSet healthy = *b.object_ls;
    for (const LevelSet& lesion : b.lesion_ls) healthy = healthy.difference(lesion);
    return healthy;
  }
  // Caries of lesion k: the object inside it, minus the lesions listed before it.
  LevelSet caries = b.object_ls->intersection(b.lesion_ls[static_cast<std::size_t>(part)]);
  for (int j = 0; j < part; ++j) caries = caries.difference(b.lesion_ls[static_cast<std::size_t>(j)]);
  return caries;
}

// The per-part progress callback: the part's name and the tree builder's fraction.
ProgressFn part_progress(const BuildOptions& options, const std::string& name) {
  if (!options.progress) return {};
  return [&options, name](std::string_view stage, double fraction) {
    options.progress(fmt::format("{}: {}", name, stage), fraction);
  };
}

// Material indices of a model: each object's healthy material (and dentin below its enamel), then
// one per lesion.
struct MaterialTable {
  std::vector<uint16_t> healthy;  // per scene object
  std::vector<int> dentin;        // per scene object, -1 when it has no enamel layer
  std::vector<uint16_t> lesion;   // per lesion
};

MaterialTable add_materials(const SceneDesc& scene, std::vector<Material>& materials) {
  MaterialTable table;
  table.healthy.resize(scene.objects.size());
  table.dentin.assign(scene.objects.size(), -1);
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const ObjectDesc& o = scene.objects[i];
    Material m = o.material;
    table.healthy[i] = static_cast<uint16_t>(materials.size());
    materials.push_back(m);
    if (o.enamel_thickness) {
      m.tissue = Tissue::Dentin;
      table.dentin[i] = static_cast<int>(materials.size());
      materials.push_back(m);
    }
  }
  table.lesion.resize(scene.lesions.size());
  for (std::size_t k = 0; k < scene.lesions.size(); ++k) {
    const LesionDesc& l = scene.lesions[k];
    Material m = l.material;
    m.lesion = static_cast<int16_t>(k);
    if (!l.world_frame) m.aniso_dir = scene.objects[static_cast<std::size_t>(l.object)].pose.q * m.aniso_dir;
    table.lesion[k] = static_cast<uint16_t>(materials.size());
    materials.push_back(m);
  }
  return table;
}

// Level sets, CSG, tree, leaf labels and display mesh of one part (-1: the healthy or whole part, else
// the k-th lesion of the object). `part_ls` keeps the part's level set for a later deviation measure.
CachedPart build_part(ObjectBuild& b, int part, int lesion, const SceneDesc& scene, const std::string& name,
                      const BuildOptions& options, std::optional<LevelSet>& part_ls) {
  const ObjectDesc& o = *b.desc;
  part_ls = part_level_set(b, part);
  CachedPart built;
  try {
    TreeLeaves leaves = build_leaves(*part_ls, b.params, part_progress(options, name));
    // A cut object: each part also gets the seam leaves on its side of the cuts, so that the parts'
    // union follows the uncut surface across every lesion's border. Then the hierarchy, once.
    if (!b.lesions.empty() && b.params.mode == TreeMode::Tight && !leaves.empty()) {
      if (!b.seam)
        b.seam = build_seam_leaves(*b.object_ls, b.shapes, b.params, {}, part_progress(options, name));
      add_seam_leaves(leaves, (*b.seam)[static_cast<std::size_t>(part + 1)], *b.object_ls, b.shapes,
                      b.params);
    }
    built.tree = build_tree(leaves, b.params.branching);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}: {}", object_context(o), name, e.what()));
  }
  if (built.tree.empty()) {
    if (lesion >= 0) {
      const LesionDesc& l = scene.lesions[static_cast<std::size_t>(lesion)];
      throw Error(fmt::format("{}: the lesion does not overlap '{}' (its caries part is empty)",
                              lesion_context(l), o.name));
    }
    throw Error(
        fmt::format("{}: {} is empty (do the lesions cover the whole object?)", object_context(o), name));
  }
  classify_leaves(built.tree, *b.object_ls,
                  b.params.mode == TreeMode::Tight ? b.params.tolerance : b.resolution().voxel);
  built.display = b.lesions.empty() ? b.world_mesh() : part_ls->to_mesh(kDisplayAdaptivity);
  return built;
}

// Leaf materials from the leaf depth: healthy enamel/dentin below the object's enamel thickness, or
// the lesion's own.
void label_part(SphereTree& tree, const ObjectDesc& o, std::size_t object, int lesion,
                const MaterialTable& table) {
  if (lesion < 0) {
    const uint16_t enamel = table.healthy[object];
    const int dentin = table.dentin[object];
    const double thickness = o.enamel_thickness.value_or(std::numeric_limits<double>::infinity());
    assign_materials(tree, [&](const Vec3&, float depth) {
      return dentin >= 0 && depth > thickness ? static_cast<uint16_t>(dentin) : enamel;
    });
  } else {
    const uint16_t m = table.lesion[static_cast<std::size_t>(lesion)];
    assign_materials(tree, [m](const Vec3&, float) { return m; });
  }
}

// Appends a built part to the model: its collision object, its display part, and the lesion it shows.
void add_part(Model& model, const SceneDesc& scene, std::size_t object_index, int healthy_index, int lesion,
              const LesionShape* shape, const std::string& name, SphereTree tree, TriangleMesh display_mesh,
              const MaterialTable& table) {
  const ObjectDesc& o = scene.objects[object_index];
  CollisionObject object;
  object.name = name;
  object.kind = o.kind;
  object.scene_object = static_cast<int16_t>(object_index);
  DisplayPart display;
  display.name = name;
  display.mesh = std::move(display_mesh);
  display.tissue = o.material.tissue;
  display.object = static_cast<int16_t>(model.objects.size());
  if (lesion >= 0) {
    const std::size_t k = static_cast<std::size_t>(lesion);
    object.lesion = static_cast<int16_t>(k);
    object.host = static_cast<int16_t>(healthy_index);
    display.tissue = Tissue::Caries;
    display.lesion = static_cast<int16_t>(k);
    LesionModel& lm = model.lesions[k];
    lm.name = scene.lesions[k].name;
    lm.object = static_cast<int16_t>(model.objects.size());
    lm.host = static_cast<int16_t>(healthy_index);
    lm.material = table.lesion[k];
    lm.shape = *shape;
    lm.authored_depth = scene.lesions[k].shape.depth;
    lm.severity = scene.lesions[k].severity;
  }
  object.tree = std::move(tree);
  // Rigid tissue (rigid_object) is met only at its surface (collide() skips its interior fillers).
  object.surface_only = rigid_object(object.tree, model.defaults.materials);
  model.objects.push_back(std::move(object));
  model.display.push_back(std::move(display));
}

// Every part of one scene object: the healthy (or whole) part, then one caries part per lesion, each
// from the cache or built. Adds the object's key to `scene_key` and a report per part to `out`.
void add_object_parts(Model& model, const SceneDesc& scene, std::size_t i, const BuildOptions& options,
                      const std::optional<TreeCache>& cache, const MaterialTable& table, BuildKey& scene_key,
                      BuildReport& out) {
  const ObjectDesc& o = scene.objects[i];
  ObjectBuild b;
  b.desc = &o;
  b.params = effective_params(o, options);
  for (std::size_t k = 0; k < scene.lesions.size(); ++k) {
    if (scene.lesions[k].object != static_cast<int>(i)) continue;
    b.lesions.push_back(static_cast<int>(k));
    const LesionDesc& l = scene.lesions[k];
    b.shapes.push_back(l.snap ? place_lesion(scene, l, b.world_mesh()) : lesion_shape_in_world(scene, l));
  }

  // What determines this object's parts (the healthy or whole part's key stands for them all).
  scene_key.add(static_cast<int64_t>(part_cache_key(o, b.params, b.shapes, -1)));

  const std::size_t part_total = scene.objects.size() + scene.lesions.size();
  const int healthy_index = static_cast<int>(model.objects.size());
  for (int part = -1; part < static_cast<int>(b.lesions.size()); ++part) {
    const auto part_start = Clock::now();
    const bool whole = b.lesions.empty();
    // The lesion this part shows (-1: the healthy or whole part).
    const int lesion = part < 0 ? -1 : b.lesions[static_cast<std::size_t>(part)];
    const std::string name =
        whole ? o.name
              : fmt::format("{}/{}", o.name,
                            lesion < 0 ? std::string("healthy")
                                       : scene.lesions[static_cast<std::size_t>(lesion)].name);
    report(options.progress, name, 0.0);
    const uint64_t key = part_cache_key(o, b.params, b.shapes, part);

    // Cached, else built (and cached).
    PartReport part_report;
    part_report.name = name;
    part_report.object = static_cast<int>(model.objects.size());
    std::optional<CachedPart> cached = cache ? cache->load(key) : std::nullopt;
    std::optional<LevelSet> part_ls;
    if (cached) {
      part_report.cache_hit = true;
    } else {
      cached = build_part(b, part, lesion, scene, name, options, part_ls);
      if (cache && (whole || options.cache_lesion_parts)) cache->store(key, *cached);
    }

    // Leaf materials, then a check that the tree is usable.
    SphereTree tree = std::move(cached->tree);
    label_part(tree, o, i, lesion, table);
    if (const std::string problem = check_tree(tree, 1e-3); !problem.empty())
      throw Error(fmt::format("{}: {}: invalid tree: {}", object_context(o), name, problem));
    part_report.build_seconds = seconds_since(part_start);

    // Surface deviation (on request): against the input mesh for a whole object, else the part's surface.
    if (options.measure_deviation) {
      if (!part_ls) part_ls = part_level_set(b, part);
      part_report.deviation = measure_deviation(tree, whole ? b.world_mesh() : cached->display, *part_ls,
                                                options.deviation_samples);
    }

    part_report.leaves = tree.leaf_count();
    part_report.levels = tree.levels;
    part_report.nodes_per_level = tree.nodes_per_level();
    add_part(model, scene, i, healthy_index, lesion,
             part < 0 ? nullptr : &b.shapes[static_cast<std::size_t>(part)], name, std::move(tree),
             std::move(cached->display), table);
    out.parts.push_back(std::move(part_report));
    report(options.progress, name, 1.0);
    report(options.progress, "scene",
           static_cast<double>(out.parts.size()) / static_cast<double>(part_total));
  }

  // An object cut by lesions is also drawn whole: its uncut surface stands for its parts while the
  // lesions are hidden (a trainee sees no seam).
  if (!b.lesions.empty()) {
    for (std::size_t k = 0; k <= b.lesions.size(); ++k)
      model.display[static_cast<std::size_t>(healthy_index) + k].cut = true;
    model.display[static_cast<std::size_t>(healthy_index)].whole = b.world_mesh();
  }

  // Seam deviation (on request): every part of the object together against its uncut surface, on a
  // band around each lesion's border.
  if (options.measure_deviation && !b.lesions.empty()) {
    make_level_sets(b);
    std::vector<const SphereTree*> trees;
    for (std::size_t k = 0; k <= b.lesions.size(); ++k)
      trees.push_back(&model.objects[static_cast<std::size_t>(healthy_index) + k].tree);
    const std::size_t first_report = out.parts.size() - b.lesions.size();
    for (std::size_t k = 0; k < b.lesions.size(); ++k) {
      const LesionShape& shape = b.shapes[k];
      out.parts[first_report + k].seam_deviation = measure_seam_deviation(
          trees, b.world_mesh(), *b.object_ls, [&shape](const Vec3& x) { return shape.distance(x); },
          kSeamBandHalfWidth, options.deviation_samples);
    }
  }
}

// The tool's home: as given, else above the scene's highest point with the tip lowest. It must be free.
Pose tool_home(const SceneDesc& scene, const Model& model) {
  Pose home;
  if (scene.tool_home) {
    home = *scene.tool_home;
  } else {
    Eigen::AlignedBox3d bounds;
    for (const DisplayPart& part : model.display) bounds.extend(part.mesh.bounds());
    home.p = Vec3(bounds.center().x(), bounds.center().y(), bounds.max().z() + kHomeClearance);
    // Tilted about the tool's y axis by half the bend: tip segment and handle rise equally, so the
    // tip is the tool's lowest point.
    home.q = Quat(Eigen::AngleAxisd(-0.5 * scene.tool.bend_angle, Vec3::UnitY()));
  }
  PlacedTool placed(model.tool.tree);
  placed.place(home, 0.0);
  const ClosestPair near = closest(placed, model.objects, kAllObjects, 0.0);
  if (near.gap < 0.0) {
    throw Error(fmt::format("{}: tool.home: the tool at its home pose overlaps '{}' by {:.3f} mm",
                            scene.origin, model.objects[near.object].name, -near.gap));
  }
  return home;
}

}  // namespace

MeshLoadOptions mesh_load_options(const ShapeDesc& shape) {
  MeshLoadOptions options;
  options.scale = shape.scale;
  return options;
}

void hash_fields(BuildKey& key, const ShapeDesc& shape) {
  // Every field (a new one fails to compile here until it is hashed); the mesh file by its bytes
  // (none for a procedural shape) and the options it is loaded with, not by its name.
  const auto& [kind, file, scale, size, molar, premolar, gingiva, tongue] = shape;
  key.add_value(kind)
      .add(file.empty() ? std::string() : file_bytes(file))
      .add_value(mesh_load_options(shape));
  key.add_value(scale).add_value(size).add_value(molar).add_value(premolar).add_value(gingiva);
  key.add_value(tongue);
}

uint64_t part_cache_key(const ObjectDesc& object, const TreeParams& params,
                        const std::vector<LesionShape>& lesions, int part) {
  // Each struct hashes every field of its own (common/hash.hpp); then this file's own constants and
  // the part. The cache adds its version (kTreeCacheVersion).
  BuildKey key;
  key.add_value(object.shape).add_value(object.pose).add_value(TreeDesc{params, object.tree.voxel});
  key.add_value(lesions).add(kDisplayAdaptivity).add(kBandVoxels).add(int64_t{part});
  return key.value();
}

namespace {

// Force shading's surfaces (Model::shading_surfaces): each rigid object's display mesh, gridded for
// nearest-point queries; for an object lesions cut, its uncut surface (the scan itself, `whole`):
// outside the lesions, where the tool meets the healthy part, the two are one surface, and the cut
// part's mesh is the level set's, not the scan's (it gave 0.030 N of ripple on 46 against the scan's
// 0.014; docs/performance.md, "Eleventh round").
constexpr double kShadingCell = 0.1;  // mm, the nearest-point grid's cell

void set_shading_surfaces(Model& model) {
  model.shading_surfaces.assign(model.objects.size(), MeshNearest());
  for (const DisplayPart& part : model.display) {
    if (part.object < 0 || static_cast<std::size_t>(part.object) >= model.objects.size() ||
        part.mesh.triangles.empty())
      continue;
    if (!rigid_object(model.objects[static_cast<std::size_t>(part.object)].tree, model.defaults.materials))
      continue;
    model.shading_surfaces[static_cast<std::size_t>(part.object)] =
        MeshNearest(!part.whole.triangles.empty() ? part.whole : part.mesh, kShadingCell);
  }
}

}  // namespace

Model build_model(const SceneDesc& scene, const BuildOptions& options, BuildReport* report_out) {
  const auto start = Clock::now();
  Model model;
  model.scene_name = scene.name;
  const std::optional<TreeCache> cache =
      options.use_cache
          ? std::optional<TreeCache>(options.cache_dir.empty() ? TreeCache() : TreeCache(options.cache_dir))
          : std::nullopt;
  BuildReport local_report;
  BuildReport& out = report_out ? *report_out : local_report;
  out.parts.clear();
  BuildKey scene_key;
  scene_key.add(static_cast<int64_t>(scene.source_hash));

  // Materials, then every object's parts (trees, display meshes, lesions).
  const MaterialTable table = add_materials(scene, model.defaults.materials);
  model.lesions.resize(scene.lesions.size());
  for (std::size_t i = 0; i < scene.objects.size(); ++i)
    add_object_parts(model, scene, i, options, cache, table, scene_key, out);

  // The tool: the explorer's sphere chain, its tree and display mesh.
  try {
    model.tool.params = scene.tool;
    model.tool.tree = build_tool_tree(make_explorer_spheres(scene.tool, scene.tool_max_gap));
    model.tool.display = make_explorer_mesh(scene.tool);
    model.tool.tip_radius = scene.tool.tip_radius;
  } catch (const Error& e) {
    throw Error(fmt::format("{}: tool: {}", scene.origin, e.what()));
  }

  // Device, coupling, rate, and the tool's home.
  model.defaults.limits = scene.limits;
  model.defaults.gains = scene.gains;
  model.servo_rate = scene.servo_rate;
  model.scene_hash = scene_key.value();
  model.tool_home = tool_home(scene, model);
  set_shading_surfaces(model);
  out.total_seconds = seconds_since(start);
  return model;
}

}  // namespace cariesim
