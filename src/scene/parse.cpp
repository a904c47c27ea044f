// Scene parsing (docs/scene-format.md): YAML text -> SceneDesc, every field checked and located.

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cctype>
#include <cmath>
#include <numbers>
#include <set>

#include "cariesim/common/error.hpp"
#include "cariesim/geometry/mesh.hpp"
#include "cariesim/geometry/procedural.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/render/params.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/spheretree/build.hpp"
#include "cariesim/spheretree/cache.hpp"
#include "overrides.hpp"

namespace cariesim {

using io::Fields;
using io::indexed;
using io::Reader;

namespace {

// Sanity bounds that keep every value physical and every build finite.
constexpr double kMaxLength = 1000.0;       // mm, largest size of anything in a scene
constexpr double kMaxCoordinate = 10000.0;  // mm, largest |coordinate| of a position
constexpr double kMinVoxel = 0.005;         // mm, finest level-set voxel
constexpr double kMinCuboidEdge = 0.01;     // mm, thinnest cuboid edge (make_cuboid takes 0.001)
// Hz, the real-time servo loop's limit (servo/servo.hpp kMaxServoRate, docs/design.md §5: up to 10 kHz);
// a scene asking for more passed `scene check` and then failed in `cariesim servo`.
constexpr double kMaxSceneServoRate = 10000.0;
// A mesh file named with this prefix lies in the shipped data folder (data_directory()).
constexpr std::string_view kDataPrefix = "data:";
constexpr double kDefaultCariesStiffness = 4.0;  // N/mm, sliding stiffness of caries without a preset
constexpr int kMaxParts = 64;                    // collision objects a model can hold (ObjectMask)

constexpr double kDegree = std::numbers::pi / 180.0;

// A position: a sequence of 3 numbers within the coordinate bounds.
Vec3 read_position(const Reader& r, const YAML::Node& node, const std::string& path) {
  const Vec3 p = r.vec3(node, path);
  if (p.cwiseAbs().maxCoeff() > kMaxCoordinate) {
    r.fail(node, path, fmt::format("coordinates must be within +/-{} mm", kMaxCoordinate));
  }
  return p;
}

// A pose: {position: [x, y, z] mm, rotation: {axis: [x, y, z], angle: degrees}}.
Pose read_pose(const Reader& r, const YAML::Node& node, const std::string& path) {
  const Fields f(r, node, path, {"position", "rotation"});
  Pose pose;
  if (const auto n = f.get("position"); n.IsDefined()) pose.p = read_position(r, n, f.sub("position"));
  if (const auto n = f.get("rotation"); n.IsDefined()) pose.q = r.rotation(n, f.sub("rotation"));
  return pose;
}

// An object's `shape`: {type: mesh|cuboid|molar|premolar|gingiva|tongue, ...parameters}.
ShapeDesc read_shape(const Reader& r, const YAML::Node& node, const std::string& path,
                     const std::filesystem::path& base_dir) {
  ShapeDesc s;
  const Fields head(
      r, node, path,
      {"type", "file", "scale", "size", "mesiodistal", "buccolingual", "crown_height", "root_length", "cusps",
       "roots", "resolution", "path", "width", "height", "length", "mirrored"});
  const std::size_t type = r.choice(head.require("type"), head.sub("type"), "shape type",
                                    {"mesh", "cuboid", "molar", "premolar", "gingiva", "tongue"});
  s.kind = static_cast<ShapeDesc::Kind>(type);
  switch (s.kind) {
    case ShapeDesc::Kind::Mesh: {
      // A mesh file, relative to the scene file or ("data:PATH") in the shipped data folder; it must
      // exist.
      const Fields f(r, node, path, {"type", "file", "scale"});
      const YAML::Node file = f.require("file");
      const std::string name = r.text(file, f.sub("file"));
      if (name.empty()) r.fail(file, f.sub("file"), "empty file name");
      const bool in_data = name.starts_with(kDataPrefix);
      const std::filesystem::path given(in_data ? name.substr(kDataPrefix.size()) : name);
      if (in_data && (given.empty() || given.is_absolute())) {
        r.fail(file, f.sub("file"),
               fmt::format("'{}': expected a relative path after '{}'", name, kDataPrefix));
      }
      const std::filesystem::path base = in_data ? data_directory() : base_dir;
      s.file = (given.is_absolute() ? given : base / given).lexically_normal();
      // A regular file: a folder, FIFO or device is named by its kind (reading one would fail or block).
      const io::FileKind kind = io::file_kind(s.file);
      if (kind != io::FileKind::Missing && kind != io::FileKind::Regular) {
        r.fail(
            file, f.sub("file"),
            fmt::format("{}: not a regular file ({}), not a mesh file", s.file.string(), io::describe(kind)));
      }
      if (kind == io::FileKind::Missing) {
        r.fail(file, f.sub("file"),
               in_data ? fmt::format("mesh file not found: {} ('{}' in the data folder {}; set "
                                     "CARIESIM_DATA_DIR to the repository's data/ folder)",
                                     s.file.string(), name, data_directory().string())
                       : fmt::format("mesh file not found: {}", s.file.string()));
      }
      f.positive("scale", s.scale, 1e4, "");
      break;
    }
    case ShapeDesc::Kind::Cuboid: {
      const Fields f(r, node, path, {"type", "size"});
      const YAML::Node size = f.require("size");
      s.size = r.vec3(size, f.sub("size"));
      if (!(s.size.minCoeff() > 0.0) || s.size.maxCoeff() > kMaxLength) {
        r.fail(size, f.sub("size"), fmt::format("edge lengths must be > 0 and <= {} mm", kMaxLength));
      }
      break;
    }
    case ShapeDesc::Kind::Molar: {
      const Fields f(r, node, path,
                     {"type", "mesiodistal", "buccolingual", "crown_height", "root_length", "cusps", "roots",
                      "resolution", "mirrored"});
      if (const auto n = f.get("mirrored"); n.IsDefined()) s.molar.mirrored = r.boolean(n, f.sub("mirrored"));
      f.number_in("mesiodistal", s.molar.mesiodistal, 5.0, 20.0, "mm");
      f.number_in("buccolingual", s.molar.buccolingual, 5.0, 20.0, "mm");
      f.number_in("crown_height", s.molar.crown_height, 3.0, 15.0, "mm");
      f.number_in("root_length", s.molar.root_length, 4.0, 30.0, "mm");
      if (const auto n = f.get("cusps"); n.IsDefined()) {
        s.molar.cusps = static_cast<int>(r.integer_in(n, f.sub("cusps"), 4, 5));
      }
      if (const auto n = f.get("roots"); n.IsDefined()) {
        s.molar.roots = static_cast<int>(r.integer_in(n, f.sub("roots"), 1, 2));
      }
      f.number_in("resolution", s.molar.resolution, 0.05, 1.0, "mm");
      break;
    }
    case ShapeDesc::Kind::Premolar: {
      const Fields f(
          r, node, path,
          {"type", "mesiodistal", "buccolingual", "crown_height", "root_length", "resolution", "mirrored"});
      if (const auto n = f.get("mirrored"); n.IsDefined())
        s.premolar.mirrored = r.boolean(n, f.sub("mirrored"));
      f.number_in("mesiodistal", s.premolar.mesiodistal, 4.0, 15.0, "mm");
      f.number_in("buccolingual", s.premolar.buccolingual, 4.0, 15.0, "mm");
      f.number_in("crown_height", s.premolar.crown_height, 3.0, 15.0, "mm");
      f.number_in("root_length", s.premolar.root_length, 4.0, 30.0, "mm");
      f.number_in("resolution", s.premolar.resolution, 0.05, 1.0, "mm");
      break;
    }
    case ShapeDesc::Kind::Gingiva: {
      // A band along a polyline of at least two distinct points.
      const Fields f(r, node, path, {"type", "path", "width", "height", "resolution"});
      const YAML::Node points = f.require("path");
      r.require_sequence(points, f.sub("path"));
      if (points.size() < 2) r.fail(points, f.sub("path"), "expected at least 2 points");
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Vec3 p = read_position(r, points[i], indexed(f.sub("path"), i));
        if (!s.gingiva.path.empty() && (p - s.gingiva.path.back()).norm() < 1e-6) {
          r.fail(points[i], indexed(f.sub("path"), i), "repeats the previous point");
        }
        s.gingiva.path.push_back(p);
      }
      f.number_in("width", s.gingiva.width, 0.5, 200.0, "mm");
      f.number_in("height", s.gingiva.height, 0.5, 100.0, "mm");
      f.number_in("resolution", s.gingiva.resolution, 0.05, 5.0, "mm");
      break;
    }
    case ShapeDesc::Kind::Tongue: {
      const Fields f(r, node, path, {"type", "length", "width", "height", "resolution"});
      f.number_in("length", s.tongue.length, 2.0, 300.0, "mm");
      f.number_in("width", s.tongue.width, 2.0, 300.0, "mm");
      f.number_in("height", s.tongue.height, 1.0, 300.0, "mm");
      f.number_in("resolution", s.tongue.resolution, 0.05, 10.0, "mm");
      break;
    }
  }
  return s;
}

// A stiffness: a number of N/mm, or `rigid`.
double read_stiffness(const Reader& r, const YAML::Node& node, const std::string& path) {
  if (node.IsDefined() && node.IsScalar() && node.Scalar() == "rigid") {
    return std::numeric_limits<double>::infinity();
  }
  if (node.IsDefined() && node.IsScalar()) {
    const std::string& s = node.Scalar();
    if (!s.empty() && std::isalpha(static_cast<unsigned char>(s.front())) != 0) {
      r.fail(node, path, fmt::format("expected a number (N/mm) or 'rigid', got '{}'", s));
    }
  }
  return r.positive(node, path, kMaxStiffness, "N/mm");
}

// A cuboid the builder would turn into an empty tree is refused here, so `scene check` and the build
// agree: a tight tree needs at least two level-set voxels across the thinnest edge (the voxel the
// builder picks, choose_resolution, or the tree's `voxel`).
void check_cuboid_fits_its_tree(const Reader& r, const Fields& f, const ObjectDesc& o) {
  if (o.shape.kind != ShapeDesc::Kind::Cuboid) return;
  const YAML::Node size = f.get("shape")["size"];
  const std::string where = f.sub("shape.size");
  const double thinnest = o.shape.size.minCoeff();  // mm
  if (thinnest < kMinCuboidEdge)
    r.fail(size, where,
           fmt::format("edge {:g} mm is below the smallest a cuboid may have, {:g} mm", thinnest,
                       kMinCuboidEdge));
  if (o.tree.params.mode != TreeMode::Tight) return;
  const double voxel =
      o.tree.voxel ? *o.tree.voxel : choose_resolution(make_cuboid(o.shape.size), o.tree.params).voxel;
  if (thinnest < 2.0 * voxel)
    r.fail(size, where,
           fmt::format(
               "edge {:g} mm is thinner than two level-set voxels of its tight tree (2 x {:g} mm): the tree "
               "would be empty; make the object larger, or lower tree.tolerance or tree.voxel",
               thinnest, voxel));
}

// An object's tree settings.
TreeDesc read_tree(const Reader& r, const YAML::Node& node, const std::string& path) {
  TreeDesc t;
  const Fields f(r, node, path,
                 {"mode", "depth", "tolerance", "max_radius", "min_radius", "voxel", "max_leaves",
                  "fill_interior", "branching"});
  if (const auto n = f.get("mode"); n.IsDefined()) {
    t.params.mode = r.choice(n, f.sub("mode"), "tree mode", {"tight", "octree"}) == 0 ? TreeMode::Tight
                                                                                      : TreeMode::Octree;
  }
  if (const auto n = f.get("depth"); n.IsDefined())
    t.params.depth = static_cast<int>(r.integer_in(n, f.sub("depth"), 1, 7));
  f.positive("tolerance", t.params.tolerance, 10.0, "mm");
  f.positive("max_radius", t.params.max_radius, 100.0, "mm");
  f.positive("min_radius", t.params.min_radius, 100.0, "mm");
  if (const auto n = f.get("voxel"); n.IsDefined())
    t.voxel = r.number_in(n, f.sub("voxel"), kMinVoxel, 10.0, "mm");
  if (const auto n = f.get("max_leaves"); n.IsDefined()) {
    t.params.max_leaves = static_cast<std::size_t>(r.integer_in(n, f.sub("max_leaves"), 1, 2000000));
  }
  if (const auto n = f.get("fill_interior"); n.IsDefined())
    t.params.fill_interior = r.boolean(n, f.sub("fill_interior"));
  if (const auto n = f.get("branching"); n.IsDefined()) {
    t.params.branching = static_cast<int>(r.integer_in(n, f.sub("branching"), 2, 8));
  }
  if (t.params.min_radius >= t.params.max_radius) {
    r.fail(f.has("min_radius") ? f.get("min_radius") : node, f.sub("min_radius"),
           fmt::format("{} mm must be below max_radius ({} mm)", t.params.min_radius, t.params.max_radius));
  }
  return t;
}

// Tissue defaults of an object: kind and healthy material.
void apply_tissue_defaults(ObjectDesc& o) {
  switch (o.material.tissue) {
    case Tissue::Gingiva:
      o.kind = ObjectKind::Soft;
      o.material.stiffness = 0.3;
      break;
    case Tissue::Tongue:
      o.kind = ObjectKind::Soft;
      o.material.stiffness = 0.15;
      break;
    default:
      o.kind = ObjectKind::Rigid;
      o.material.stiffness = std::numeric_limits<double>::infinity();
      break;
  }
}

// One entry of `objects`.
ObjectDesc read_object(const Reader& r, const YAML::Node& node, const std::string& path,
                       const std::filesystem::path& base_dir) {
  const Fields f(r, node, path,
                 {"name", "fdi", "shape", "pose", "kind", "tissue", "material", "enamel_thickness", "tree"});
  ObjectDesc o;
  o.where = SourceLoc{r.file(), node.Mark().line + 1, node.Mark().column + 1};
  const YAML::Node name = f.require("name");
  o.name = r.text(name, f.sub("name"));
  if (o.name.empty()) r.fail(name, f.sub("name"), "empty name");
  if (const auto n = f.get("fdi"); n.IsDefined()) {
    o.fdi = static_cast<int>(r.integer_in(n, f.sub("fdi"), 11, 48));
    if (o.fdi % 10 < 1 || o.fdi % 10 > 8) {
      r.fail(n, f.sub("fdi"), fmt::format("{} is not an FDI tooth number (quadrant 1-4, tooth 1-8)", o.fdi));
    }
  }
  o.shape = read_shape(r, f.require("shape"), f.sub("shape"), base_dir);
  if (const auto n = f.get("pose"); n.IsDefined()) o.pose = read_pose(r, n, f.sub("pose"));

  // Tissue first: it sets the defaults of kind and material.
  if (const auto n = f.get("tissue"); n.IsDefined()) {
    const std::size_t t =
        r.choice(n, f.sub("tissue"), "tissue", {"enamel", "dentin", "gingiva", "tongue", "generic"});
    constexpr Tissue kTissues[] = {Tissue::Enamel, Tissue::Dentin, Tissue::Gingiva, Tissue::Tongue,
                                   Tissue::Generic};
    o.material.tissue = kTissues[t];
  }
  apply_tissue_defaults(o);
  if (const auto n = f.get("kind"); n.IsDefined()) {
    o.kind =
        r.choice(n, f.sub("kind"), "kind", {"rigid", "soft"}) == 0 ? ObjectKind::Rigid : ObjectKind::Soft;
  }
  if (const auto n = f.get("material"); n.IsDefined()) {
    const Fields m(r, n, f.sub("material"), {"stiffness", "mu_s", "mu_d"});
    if (const auto s = m.get("stiffness"); s.IsDefined())
      o.material.stiffness = read_stiffness(r, s, m.sub("stiffness"));
    m.number_in("mu_s", o.material.mu_s, 0.0, kMaxFriction, "");
    m.number_in("mu_d", o.material.mu_d, 0.0, kMaxFriction, "");
  }
  if (o.kind == ObjectKind::Soft && !std::isfinite(o.material.stiffness)) {
    r.fail(f.has("material") ? f.get("material") : node, f.sub("material.stiffness"),
           "a soft object needs a finite stiffness (N/mm)");
  }
  if (const auto n = f.get("enamel_thickness"); n.IsDefined()) {
    if (o.material.tissue != Tissue::Enamel)
      r.fail(n, f.sub("enamel_thickness"), "only applies to tissue enamel");
    o.enamel_thickness = r.positive(n, f.sub("enamel_thickness"), 10.0, "mm");
  }
  if (const auto n = f.get("tree"); n.IsDefined()) o.tree = read_tree(r, n, f.sub("tree"));
  check_cuboid_fits_its_tree(r, f, o);
  return o;
}

// A lesion's `shape`: {type, size, width, depth, points} per LesionShape.
void read_lesion_shape(const Reader& r, const YAML::Node& node, const std::string& path, LesionShape& s) {
  const Fields head(r, node, path, {"type", "size", "width", "depth", "points"});
  const std::size_t type =
      r.choice(head.require("type"), head.sub("type"), "lesion shape",
               {"disk", "circle", "stripe", "square", "triangle", "polygon", "inverted-cone", "ellipsoid"});
  constexpr LesionShape::Kind kKinds[] = {LesionShape::Kind::Disk,         LesionShape::Kind::Disk,
                                          LesionShape::Kind::Stripe,       LesionShape::Kind::Polygon,
                                          LesionShape::Kind::Polygon,      LesionShape::Kind::Polygon,
                                          LesionShape::Kind::InvertedCone, LesionShape::Kind::Ellipsoid};
  s.kind = kKinds[type];
  const bool has_width = s.kind == LesionShape::Kind::Stripe || s.kind == LesionShape::Kind::Ellipsoid;
  const bool is_polygon = type == 5;
  // Only the keys that apply to this shape are accepted.
  std::initializer_list<std::string_view> keys_sized = {"type", "size", "depth"};
  std::initializer_list<std::string_view> keys_wide = {"type", "size", "width", "depth"};
  std::initializer_list<std::string_view> keys_polygon = {"type", "points", "depth"};
  const Fields f(r, node, path, is_polygon ? keys_polygon : (has_width ? keys_wide : keys_sized));
  s.depth = r.positive(f.require("depth"), f.sub("depth"), 100.0, "mm");
  if (is_polygon) {
    // Vertices in the (tangent, normal x tangent) plane; made counter-clockwise.
    const YAML::Node points = f.require("points");
    r.require_sequence(points, f.sub("points"));
    if (points.size() < 3 || points.size() > 64) r.fail(points, f.sub("points"), "expected 3 to 64 points");
    s.polygon.clear();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d p = r.vec2(points[i], indexed(f.sub("points"), i));
      if (p.cwiseAbs().maxCoeff() > kMaxLength)
        r.fail(points[i], indexed(f.sub("points"), i), "point too far");
      s.polygon.push_back(p);
    }
    double area = 0.0;
    for (std::size_t i = 0; i < s.polygon.size(); ++i) {
      const auto& a = s.polygon[i];
      const auto& b = s.polygon[(i + 1) % s.polygon.size()];
      area += 0.5 * (a.x() * b.y() - b.x() * a.y());
    }
    if (std::abs(area) < 1e-6) r.fail(points, f.sub("points"), "the polygon has no area");
    if (area < 0.0) std::reverse(s.polygon.begin(), s.polygon.end());
    double extent = 0.0;
    for (const auto& p : s.polygon) extent = std::max(extent, p.norm());
    s.size = 2.0 * extent;
    return;
  }
  s.size = r.positive(f.require("size"), f.sub("size"), kMaxLength, "mm");
  if (type == 3) s.polygon = LesionShape::square(s.size);
  if (type == 4) s.polygon = LesionShape::triangle(s.size);
  if (has_width) f.positive("width", s.width, kMaxLength, "mm");
}

// A k_c profile: a number (constant), {layers: [{to, k_c}...]} or {gradient: {top, bottom, to}}.
KcProfile read_kc(const Reader& r, const YAML::Node& node, const std::string& path, double lesion_depth) {
  KcProfile k;
  if (node.IsDefined() && node.IsScalar()) {
    k.kind = KcProfile::Kind::Constant;
    k.values.fill(r.positive(node, path, kMaxStiffness, "N/mm"));
    k.layer_count = 1;
    return k;
  }
  const Fields f(r, node, path, {"layers", "gradient"});
  if (f.has("layers") == f.has("gradient")) {
    r.fail(node, path, "expected a number (N/mm), or exactly one of 'layers' and 'gradient'");
  }
  if (f.has("layers")) {
    // Layers from the surface down, each reaching `to` mm with its own k_c.
    const YAML::Node layers = f.get("layers");
    r.require_sequence(layers, f.sub("layers"));
    if (layers.size() < 1 || layers.size() > static_cast<std::size_t>(KcProfile::kMaxLayers)) {
      r.fail(layers, f.sub("layers"), fmt::format("expected 1 to {} layers", KcProfile::kMaxLayers));
    }
    k.kind = KcProfile::Kind::Layers;
    k.layer_count = static_cast<int>(layers.size());
    double previous = 0.0;
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const std::string lp = indexed(f.sub("layers"), i);
      const Fields layer(r, layers[i], lp, {"to", "k_c"});
      const YAML::Node to = layer.require("to");
      const double bottom = r.positive(to, layer.sub("to"), 100.0, "mm");
      if (bottom <= previous) {
        r.fail(to, layer.sub("to"), fmt::format("must be deeper than the layer above ({} mm)", previous));
      }
      previous = bottom;
      k.bounds[i] = bottom;
      k.values[i] = r.positive(layer.require("k_c"), layer.sub("k_c"), kMaxStiffness, "N/mm");
    }
    return k;
  }
  // Linear from `top` at the surface to `bottom` at depth `to` (default: the lesion's depth).
  const Fields g(r, f.get("gradient"), f.sub("gradient"), {"top", "bottom", "to"});
  k.kind = KcProfile::Kind::Gradient;
  k.layer_count = 1;
  k.values = {r.positive(g.require("top"), g.sub("top"), kMaxStiffness, "N/mm"),
              r.positive(g.require("bottom"), g.sub("bottom"), kMaxStiffness, "N/mm"), 0.0, 0.0};
  k.bounds = {lesion_depth, 0.0, 0.0, 0.0};
  g.positive("to", k.bounds[0], 100.0, "mm");
  return k;
}

// A lesion's material: preset (severity) plus overrides.
void read_lesion_material(const Reader& r, const YAML::Node& node, const std::string& path, LesionDesc& l) {
  const Fields f(r, node, path,
                 {"stiffness", "k_e", "mu_s", "mu_d", "anisotropic", "k_c", "crush_length", "f_p_star",
                  "f_e_star", "k_theta"});
  Material& m = l.material;
  // The sliding contact stiffness is its own parameter (see caries_preset): k_e does not change it.
  f.positive("k_e", m.k_e, kMaxStiffness, "N/mm");
  if (const auto n = f.get("stiffness"); n.IsDefined())
    m.stiffness = read_stiffness(r, n, f.sub("stiffness"));
  f.number_in("mu_s", m.mu_s, 0.0, kMaxFriction, "");
  f.number_in("mu_d", m.mu_d, 0.0, kMaxFriction, "");
  if (const auto n = f.get("anisotropic"); n.IsDefined()) {
    const Fields a(r, n, f.sub("anisotropic"), {"direction", "mu_s", "mu_d"});
    m.aniso_dir = r.direction(a.require("direction"), a.sub("direction"));
    m.mu_s_along = r.number_in(a.require("mu_s"), a.sub("mu_s"), 0.0, kMaxFriction, "");
    m.mu_d_along = r.number_in(a.require("mu_d"), a.sub("mu_d"), 0.0, kMaxFriction, "");
  }
  if (const auto n = f.get("k_c"); n.IsDefined()) m.k_c = read_kc(r, n, f.sub("k_c"), l.shape.depth);
  f.positive("crush_length", m.crush_length, 100.0, "mm");
  f.positive("f_p_star", m.f_p_star, kMaxThreshold, "N");
  f.positive("f_e_star", m.f_e_star, kMaxThreshold, "N");
  f.positive("k_theta", m.k_theta, kMaxStiffness, "N·mm/rad");
  // The rules every source of material values follows (render/params.hpp), at the field they name.
  if (const ParamProblem problem = check_material(m)) {
    const std::string field(problem.field);
    const std::string top = field.substr(0, field.find('.'));
    r.fail(f.has(top) ? f.get(top) : node, f.sub(field), problem.rule);
  }
}

// One entry of `lesions` (objects are already known).
LesionDesc read_lesion(const Reader& r, const YAML::Node& node, const std::string& path,
                       const SceneDesc& scene) {
  const Fields f(r, node, path, {"name", "object", "placement", "shape", "severity", "material"});
  LesionDesc l;
  l.where = SourceLoc{r.file(), node.Mark().line + 1, node.Mark().column + 1};
  const YAML::Node name = f.require("name");
  l.name = r.text(name, f.sub("name"));
  if (l.name.empty()) r.fail(name, f.sub("name"), "empty name");

  // The host object must exist and be rigid.
  const YAML::Node object = f.require("object");
  const std::string host = r.text(object, f.sub("object"));
  l.object = scene.find_object(host);
  if (l.object < 0) {
    std::string names;
    for (const auto& o : scene.objects) names += (names.empty() ? "" : ", ") + o.name;
    r.fail(object, f.sub("object"), fmt::format("unknown object '{}' (objects: {})", host, names));
  }
  if (scene.objects[static_cast<std::size_t>(l.object)].kind != ObjectKind::Rigid) {
    r.fail(object, f.sub("object"), fmt::format("'{}' is soft; lesions need a rigid host", host));
  }

  // Shape, then placement (the shape's depth sets the default gradient depth of k_c).
  read_lesion_shape(r, f.require("shape"), f.sub("shape"), l.shape);
  const Fields p(r, f.require("placement"), f.sub("placement"),
                 {"at", "normal", "tangent", "frame", "snap", "snap_range"});
  l.shape.center = read_position(r, p.require("at"), p.sub("at"));
  l.shape.normal = r.direction(p.require("normal"), p.sub("normal"));
  if (const auto n = p.get("tangent"); n.IsDefined()) {
    const Vec3 t = r.direction(n, p.sub("tangent"));
    if ((t - t.dot(l.shape.normal) * l.shape.normal).norm() < 1e-3) {
      r.fail(n, p.sub("tangent"), "must not be parallel to the normal");
    }
    l.shape.tangent = t;
  } else {
    // Default in-plane orientation: the frame's x axis, or y when x is along the normal.
    l.shape.tangent = std::abs(l.shape.normal.x()) > 0.9 ? Vec3::UnitY() : Vec3::UnitX();
  }
  if (const auto n = p.get("frame"); n.IsDefined()) {
    l.world_frame = r.choice(n, p.sub("frame"), "frame", {"object", "world"}) == 1;
  }
  if (const auto n = p.get("snap"); n.IsDefined()) l.snap = r.boolean(n, p.sub("snap"));
  p.positive("snap_range", l.snap_range, 50.0, "mm");

  // Material: the severity preset (or the caries defaults), then the overrides.
  l.material = Material{};
  l.material.tissue = Tissue::Caries;
  l.material.stiffness = kDefaultCariesStiffness;
  if (const auto n = f.get("severity"); n.IsDefined()) {
    const std::size_t s = r.choice(n, f.sub("severity"), "severity", {"mild", "severe"});
    l.severity = s == 0 ? "mild" : "severe";
    l.material = caries_preset(s == 0 ? CariesPreset::Mild : CariesPreset::Severe);
    l.material.tissue = Tissue::Caries;
  }
  if (const auto n = f.get("material"); n.IsDefined()) read_lesion_material(r, n, f.sub("material"), l);
  return l;
}

// The `tool` section: explorer parameters and the home pose.
void read_tool(const Reader& r, const YAML::Node& node, const std::string& path, SceneDesc& scene) {
  const Fields f(r, node, path,
                 {"tip_radius", "tip_segment", "working_end_radius", "bend_radius", "bend_angle",
                  "shank_length", "shank_radius", "handle_length", "handle_radius", "max_gap", "home"});
  ExplorerParams& t = scene.tool;
  f.number_in("tip_radius", t.tip_radius, 0.005, 2.0, "mm");
  f.positive("tip_segment", t.tip_segment, 50.0, "mm");
  f.positive("working_end_radius", t.working_end_radius, 5.0, "mm");
  f.positive("bend_radius", t.bend_radius, 50.0, "mm");
  if (const auto n = f.get("bend_angle"); n.IsDefined()) {
    t.bend_angle = r.number_in(n, f.sub("bend_angle"), 1.0, 180.0, "degrees") * kDegree;
  }
  f.positive("shank_length", t.shank_length, 200.0, "mm");
  f.positive("shank_radius", t.shank_radius, 10.0, "mm");
  f.positive("handle_length", t.handle_length, 300.0, "mm");
  f.positive("handle_radius", t.handle_radius, 20.0, "mm");
  f.number_in("max_gap", scene.tool_max_gap, 0.001, 1.0, "mm");
  if (const auto n = f.get("home"); n.IsDefined()) scene.tool_home = read_pose(r, n, f.sub("home"));
  // The explorer's shape constraints: radii grow toward the handle, the bend is wider than the wire.
  const auto at = [&](std::string_view key) { return f.has(key) ? f.get(key) : node; };
  if (!(t.tip_radius <= t.working_end_radius && t.working_end_radius <= t.shank_radius &&
        t.shank_radius <= t.handle_radius)) {
    r.fail(
        node, path,
        fmt::format("radii must grow from the tip to the handle: tip_radius {} <= working_end_radius {} <= "
                    "shank_radius {} <= handle_radius {} mm",
                    t.tip_radius, t.working_end_radius, t.shank_radius, t.handle_radius));
  }
  if (!(t.working_end_radius < t.bend_radius)) {
    r.fail(at("bend_radius"), f.sub("bend_radius"),
           fmt::format("must exceed working_end_radius ({} mm)", t.working_end_radius));
  }
  if (!(t.handle_length > 2.0 * t.handle_radius + std::min(6.0, 0.25 * t.handle_length))) {
    r.fail(at("handle_length"), f.sub("handle_length"),
           fmt::format("{} mm is too short for handle_radius {} mm", t.handle_length, t.handle_radius));
  }
}

// The `device` section: limits of the haptic device.
void read_device(const Reader& r, const YAML::Node& node, const std::string& path, DeviceLimits& d) {
  const Fields f(r, node, path,
                 {"max_force", "max_stiffness", "max_torque", "position_resolution", "workspace"});
  f.positive("max_force", d.max_force, 1000.0, "N");
  f.positive("max_stiffness", d.max_stiffness, 1000.0, "N/mm");
  f.positive("max_torque", d.max_torque, 1e5, "N·mm");
  f.positive("position_resolution", d.position_resolution, 10.0, "mm");
  if (const auto n = f.get("workspace"); n.IsDefined()) {
    const Fields w(r, n, f.sub("workspace"), {"min", "max"});
    const Vec3 lo = read_position(r, w.require("min"), w.sub("min"));
    const Vec3 hi = read_position(r, w.require("max"), w.sub("max"));
    if (!(lo.array() < hi.array()).all())
      r.fail(n, f.sub("workspace"), "min must be below max on every axis");
    d.workspace = Eigen::AlignedBox3d(lo, hi);
  }
  if (const ParamProblem problem = check_limits(d)) {
    const std::string field(problem.field);
    r.fail(f.has(field) ? f.get(field) : node, f.sub(field), problem.rule);
  }
}

// Scene-wide consistency: unique names and tooth numbers, part count.
void check_scene(const Reader& r, const YAML::Node& root, SceneDesc& scene) {
  const YAML::Node objects = root["objects"];
  std::set<std::string> names;
  std::set<int> teeth;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const ObjectDesc& o = scene.objects[i];
    if (!names.insert(o.name).second) {
      r.fail(objects[i]["name"], indexed("objects", i) + ".name",
             fmt::format("duplicate object name '{}'", o.name));
    }
    if (o.fdi != 0 && !teeth.insert(o.fdi).second) {
      r.fail(objects[i]["fdi"], indexed("objects", i) + ".fdi", fmt::format("tooth {} appears twice", o.fdi));
    }
  }
  const YAML::Node lesions = root["lesions"];
  std::set<std::string> lesion_names;
  for (std::size_t i = 0; i < scene.lesions.size(); ++i) {
    if (!lesion_names.insert(scene.lesions[i].name).second) {
      r.fail(lesions[i]["name"], indexed("lesions", i) + ".name",
             fmt::format("duplicate lesion name '{}'", scene.lesions[i].name));
    }
  }
  if (scene.objects.size() + scene.lesions.size() > static_cast<std::size_t>(kMaxParts)) {
    r.fail(root, "", fmt::format("a scene holds at most {} parts (objects + lesions)", kMaxParts));
  }
}

}  // namespace

std::string SourceLoc::str() const {
  if (line <= 0) return file;
  return fmt::format("{}:{}:{}", file, line, column);
}

std::string_view shape_kind_name(ShapeDesc::Kind kind) {
  switch (kind) {
    case ShapeDesc::Kind::Mesh:
      return "mesh";
    case ShapeDesc::Kind::Cuboid:
      return "cuboid";
    case ShapeDesc::Kind::Molar:
      return "molar";
    case ShapeDesc::Kind::Premolar:
      return "premolar";
    case ShapeDesc::Kind::Gingiva:
      return "gingiva";
    case ShapeDesc::Kind::Tongue:
      return "tongue";
  }
  return "unknown";
}

int SceneDesc::find_object(std::string_view object_name) const {
  for (std::size_t i = 0; i < objects.size(); ++i) {
    if (objects[i].name == object_name) return static_cast<int>(i);
  }
  return -1;
}

LesionShape lesion_shape_in_world(const SceneDesc& scene, const LesionDesc& lesion) {
  LesionShape s = lesion.shape;
  if (!lesion.world_frame) {
    const Pose& pose = scene.objects.at(static_cast<std::size_t>(lesion.object)).pose;
    s.center = pose.transform(s.center);
    s.normal = pose.q * s.normal;
    s.tangent = pose.q * s.tangent;
  }
  return s;
}

SceneDesc parse_scene(std::string_view yaml, const std::filesystem::path& origin) {
  return parse_scene(yaml, origin, {});
}

SceneDesc parse_scene(std::string_view yaml, const std::filesystem::path& origin,
                      std::span<const SceneOverride> overrides) {
  Reader r(origin.string());
  SceneDesc scene;
  scene.origin = origin.string();
  // The overrides are part of what the scene is (the tree cache's key and the records' hash).
  BuildKey hash;
  hash.add(yaml);
  for (const SceneOverride& o : overrides) hash.add(o.key).add(o.value);
  scene.source_hash = hash.value();
  scene.overrides.assign(overrides.begin(), overrides.end());

  // One strict document (size, syntax, aliases: io::parse_document), then the overrides placed in it.
  YAML::Node root = io::parse_document(yaml, origin.string());
  scene_detail::apply_overrides(root, overrides, r);

  try {
    const Fields f(
        r, root, "",
        {"name", "description", "format", "objects", "lesions", "tool", "device", "coupling", "servo_rate"});
    if (const auto n = f.get("format"); n.IsDefined()) (void)r.integer_in(n, "format", 1, 1);
    scene.name = f.has("name") ? r.text(f.get("name"), "name") : origin.stem().string();
    if (const auto n = f.get("description"); n.IsDefined()) scene.description = r.text(n, "description");

    // Objects, then lesions (which refer to objects by name).
    const YAML::Node objects = f.require("objects");
    r.require_sequence(objects, "objects");
    if (objects.size() == 0) r.fail(objects, "objects", "a scene needs at least one object");
    const std::filesystem::path base_dir = origin.parent_path();
    for (std::size_t i = 0; i < objects.size(); ++i) {
      scene.objects.push_back(read_object(r, objects[i], indexed("objects", i), base_dir));
    }
    if (const auto lesions = f.get("lesions"); lesions.IsDefined() && !lesions.IsNull()) {
      r.require_sequence(lesions, "lesions");
      for (std::size_t i = 0; i < lesions.size(); ++i) {
        scene.lesions.push_back(read_lesion(r, lesions[i], indexed("lesions", i), scene));
      }
    }

    // Tool, device, coupling, servo rate.
    if (const auto n = f.get("tool"); n.IsDefined()) read_tool(r, n, "tool", scene);
    if (const auto n = f.get("device"); n.IsDefined()) read_device(r, n, "device", scene.limits);
    scene.gains.k_trans = scene.limits.max_stiffness;
    if (const auto n = f.get("coupling"); n.IsDefined()) {
      const Fields c(r, n, "coupling", {"k_trans", "k_rot"});
      c.positive("k_trans", scene.gains.k_trans, 1000.0, "N/mm");
      c.positive("k_rot", scene.gains.k_rot, 1e6, "N·mm/rad");
    }
    if (const auto n = f.get("servo_rate"); n.IsDefined()) {
      scene.servo_rate = r.number_in(n, "servo_rate", 100.0, kMaxSceneServoRate, "Hz");
    }
    check_scene(r, root, scene);
  } catch (const YAML::Exception& e) {
    // A structural surprise inside yaml-cpp (e.g. a bad subscript): still located.
    throw Error(fmt::format("{}: {}", r.where(e.mark), e.msg));
  }
  return scene;
}

SceneDesc mesh_scene(const std::filesystem::path& mesh, const TreeDesc& tree) {
  (void)io::require_regular_file(mesh, "mesh", kMaxMeshFileBytes);
  SceneDesc scene;
  scene.name = mesh.stem().string();
  scene.origin = mesh.string();
  scene.source_hash = BuildKey().add(mesh.string()).value();
  ObjectDesc object;
  object.name = mesh.stem().string();
  object.where = SourceLoc{mesh.string(), 0, 0};
  object.shape.kind = ShapeDesc::Kind::Mesh;
  object.shape.file = mesh;
  object.tree = tree;
  scene.objects.push_back(std::move(object));
  return scene;
}

SceneDesc load_scene(const std::string& name_or_file) { return load_scene(name_or_file, {}); }

SceneDesc load_scene(const std::string& name_or_file, std::span<const SceneOverride> overrides) {
  // A built-in scene by name, else a file.
  const io::NamedText source =
      io::builtin_or_file(name_or_file, "scene", builtin_scene_yaml(name_or_file), builtin_scene_names());
  return parse_scene(source.text, source.origin, overrides);
}

}  // namespace cariesim
