// Study files (docs/training.md): YAML -> Study, every field checked and located as the scene parser
// does (it shares the scene's strict reader), the built-in studies, and making a trial from its seed.

#include "cariesim/training/study.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <random>
#include <set>

#include "cariesim/common/error.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/spheretree/cache.hpp"
#include "cariesim/training/course.hpp"
#include "training/builtin_studies.hpp"
#include "training/draws.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

using io::Fields;
using io::indexed;
using io::Reader;

namespace {

constexpr int kMaxTrials = 1000;                        // trials per participant a study may ask for
constexpr double kMaxLength = 1000.0;                   // mm, largest size of anything a study places
constexpr double kMaxTimeLimit = 3600.0;                // s, longest diagnosis case

// Slider bounds a tuning parameter may have (the engine's check_material accepts these).
struct ParamBounds {
  std::string_view name;
  std::string_view unit;
  double lo, hi;                    // what a slider may span
  double default_min, default_max;  // the slider when the study file does not say
};
constexpr ParamBounds kTunable[] = {
    {kScoreMuS, "", 0.0, 5.0, 0.0, 1.0},
    {kScoreMuD, "", 0.0, 5.0, 0.0, 1.0},
    {kScoreKc, "N/mm", 0.01, 100.0, 0.05, 2.0},
    {kScoreKe, "N/mm", 0.01, 100.0, 0.05, 2.0},
};

const ParamBounds* find_tunable(std::string_view name) {
  for (const ParamBounds& b : kTunable)
    if (b.name == name) return &b;
  return nullptr;
}

// A [min, max] pair of numbers within [lo, hi], min <= max.
void read_range(const Reader& r, const YAML::Node& node, const std::string& path, double lo, double hi,
                std::string_view unit, double& out_min, double& out_max) {
  r.require_sequence(node, path);
  if (node.size() != 2) r.fail(node, path, "expected [min, max]");
  const double a = r.number_in(node[0], indexed(path, 0), lo, hi, unit);
  const double b = r.number_in(node[1], indexed(path, 1), lo, hi, unit);
  if (a > b) r.fail(node, path, fmt::format("min {} is above max {}", a, b));
  out_min = a;
  out_max = b;
}

// The `tuning` section.
void read_tuning(const Reader& r, const YAML::Node& node, const std::string& path, TuningDesc& t) {
  const Fields f(r, node, path, {"target", "scene", "lesion", "parameters", "levels"});
  t.target = r.choice(f.require("target"), f.sub("target"), "tuning target", {"roughness", "insertion"}) == 0
                 ? TuningTarget::Roughness
                 : TuningTarget::Insertion;
  if (const auto n = f.get("scene"); n.IsDefined()) t.scene = r.text(n, f.sub("scene"));
  if (const auto n = f.get("lesion"); n.IsDefined()) t.lesion = r.text(n, f.sub("lesion"));
  // Sliders: the target's two parameters, with the study's ranges where it gives them.
  const std::string_view names[2] = {t.target == TuningTarget::Roughness ? kScoreMuS : kScoreKc,
                                     t.target == TuningTarget::Roughness ? kScoreMuD : kScoreKe};
  t.parameters.clear();
  for (const std::string_view name : names) {
    const ParamBounds& b = *find_tunable(name);
    t.parameters.push_back({std::string(name), std::string(b.unit), b.default_min, b.default_max, 0.0});
  }
  if (const auto n = f.get("parameters"); n.IsDefined()) {
    const Fields p(r, n, f.sub("parameters"), {kScoreMuS, kScoreMuD, kScoreKc, kScoreKe});
    for (const std::string_view key : {kScoreMuS, kScoreMuD, kScoreKc, kScoreKe}) {
      if (!p.has(key)) continue;
      auto it = std::find_if(t.parameters.begin(), t.parameters.end(),
                             [&](const TunedParameter& q) { return q.name == key; });
      if (it == t.parameters.end()) {
        r.fail(
            p.get(key), p.sub(key),
            fmt::format("not tuned with target '{}' (it tunes {} and {})",
                        t.target == TuningTarget::Roughness ? "roughness" : "insertion", names[0], names[1]));
      }
      const ParamBounds& b = *find_tunable(key);
      read_range(r, p.get(key), p.sub(key), b.lo, b.hi, b.unit, it->min, it->max);
    }
  }
  if (const auto n = f.get("levels"); n.IsDefined()) {
    r.require_sequence(n, f.sub("levels"));
    if (n.size() < 1 || n.size() > 2) r.fail(n, f.sub("levels"), "expected one or two levels");
    t.levels.clear();
    for (std::size_t i = 0; i < n.size(); ++i) {
      const Grade g = r.choice(n[i], indexed(f.sub("levels"), i), "level", {"mild", "severe"}) == 0
                          ? Grade::Mild
                          : Grade::Severe;
      if (std::find(t.levels.begin(), t.levels.end(), g) != t.levels.end())
        r.fail(n[i], indexed(f.sub("levels"), i), "level listed twice");
      t.levels.push_back(g);
    }
  }
}

// The `boundary` section.
void read_boundary(const Reader& r, const YAML::Node& node, const std::string& path, BoundaryDesc& b) {
  const Fields f(r, node, path,
                 {"cube", "spacing", "shape_size", "depth", "mu_s", "mu_d", "stiffness", "shapes"});
  if (const auto n = f.get("cube"); n.IsDefined()) {
    b.cube = r.vec3(n, f.sub("cube"));
    if (!(b.cube.minCoeff() > 0.0) || b.cube.maxCoeff() > kMaxLength)
      r.fail(n, f.sub("cube"), fmt::format("edges must be in (0, {}] mm", kMaxLength));
  }
  f.positive("spacing", b.spacing, 10.0 * kMaxLength, "mm");
  f.positive("shape_size", b.shape_size, kMaxLength, "mm");
  f.positive("depth", b.depth, kMaxLength, "mm");
  f.number_in("mu_s", b.mu_s, 0.0, 5.0, "");
  f.number_in("mu_d", b.mu_d, 0.0, 5.0, "");
  f.positive("stiffness", b.stiffness, 1e6, "N/mm");
  if (const auto n = f.get("shapes"); n.IsDefined()) {
    r.require_sequence(n, f.sub("shapes"));
    if (n.size() < 2 || n.size() > 6) r.fail(n, f.sub("shapes"), "expected 2 to 6 shapes");
    b.shapes.clear();
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::size_t k =
          r.choice(n[i], indexed(f.sub("shapes"), i), "shape", {"square", "triangle", "circle"});
      b.shapes.emplace_back(std::array<std::string_view, 3>{"square", "triangle", "circle"}[k]);
    }
  }
  // Each shape must fit in its cube's top face, and the cubes must not overlap.
  const double footprint = b.shape_size;
  if (footprint >= std::min(b.cube.x(), b.cube.y())) {
    r.fail(f.has("shape_size") ? f.get("shape_size") : node, f.sub("shape_size"),
           fmt::format("{} mm does not fit in the cube's {} x {} mm top", footprint, b.cube.x(), b.cube.y()));
  }
  if (b.depth >= b.cube.z())
    r.fail(f.has("depth") ? f.get("depth") : node, f.sub("depth"), "must be less than the cube's height");
  if (b.spacing <= b.cube.x())
    r.fail(f.has("spacing") ? f.get("spacing") : node, f.sub("spacing"), "the cubes would overlap");
}

// The shapes a lesion may take, as the study file names them.
constexpr std::string_view kShapeNames[] = {"disk", "stripe", "ellipsoid", "inverted-cone"};
constexpr LesionShape::Kind kShapeKinds[] = {LesionShape::Kind::Disk, LesionShape::Kind::Stripe,
                                             LesionShape::Kind::Ellipsoid, LesionShape::Kind::InvertedCone};
constexpr double kMaxRegion = 20.0;  // mm, largest half-axis of a site's region
// The kinds of site (site_kind_names()).
constexpr std::string_view kSiteKinds[] = {"occlusal",    "occlusal-fossa", "occlusal-fissure", "buccal-pit",
                                           "lingual-pit", "interproximal",  "mesial",           "distal"};

LesionShape::Kind read_shape(const Reader& r, const YAML::Node& node, const std::string& path) {
  return kShapeKinds[r.choice(node, path, "lesion shape",
                              {kShapeNames[0], kShapeNames[1], kShapeNames[2], kShapeNames[3]})];
}

// One entry of `diagnosis.sites`, checked against the scene's objects.
LesionSite read_site(const Reader& r, const YAML::Node& node, const std::string& path,
                     const SceneDesc& scene) {
  const Fields f(
      r, node, path,
      {"name", "object", "site", "at", "normal", "tangent", "region", "snap_range", "shape", "shapes"});
  LesionSite s;
  s.where = SourceLoc{r.file(), node.Mark().line + 1, node.Mark().column + 1};
  s.name = r.text(f.require("name"), f.sub("name"));
  if (s.name.empty()) r.fail(f.get("name"), f.sub("name"), "empty name");
  s.object = r.text(f.require("object"), f.sub("object"));
  const int object = scene.find_object(s.object);
  if (object < 0) {
    std::string names;
    for (const auto& o : scene.objects) names += (names.empty() ? "" : ", ") + o.name;
    r.fail(f.get("object"), f.sub("object"),
           fmt::format("no object '{}' in scene {} (objects: {})", s.object, scene.name, names));
  }
  const ObjectDesc& o = scene.objects[static_cast<std::size_t>(object)];
  if (o.kind != ObjectKind::Rigid) r.fail(f.get("object"), f.sub("object"), "lesions need a rigid host");
  s.fdi = o.fdi;
  const auto& k = kSiteKinds;
  s.site = std::string(k[r.choice(f.require("site"), f.sub("site"), "site",
                                  {k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]})]);
  s.at = r.vec3(f.require("at"), f.sub("at"));
  if (s.at.cwiseAbs().maxCoeff() > 10.0 * kMaxLength) r.fail(f.get("at"), f.sub("at"), "point too far");
  s.world_at = o.pose.transform(s.at);
  s.normal = r.direction(f.require("normal"), f.sub("normal"));
  if (const auto n = f.get("tangent"); n.IsDefined()) {
    s.tangent = r.direction(n, f.sub("tangent"));
    if ((s.tangent - s.tangent.dot(s.normal) * s.normal).norm() < 1e-3)
      r.fail(n, f.sub("tangent"), "must not be parallel to the normal");
  } else {
    s.tangent = std::abs(s.normal.x()) > 0.9 ? Vec3::UnitY() : Vec3::UnitX();
  }
  // The region: two half-axes (mm), each in [0, kMaxRegion].
  if (const auto n = f.get("region"); n.IsDefined()) {
    r.require_sequence(n, f.sub("region"));
    if (n.size() != 2) r.fail(n, f.sub("region"), "expected [along, across] (mm, the ellipse's half-axes)");
    for (std::size_t i = 0; i < 2; ++i)
      s.region[i] = r.number_in(n[i], indexed(f.sub("region"), i), 0.0, kMaxRegion, "mm");
  }
  f.positive("snap_range", s.snap_range, 50.0, "mm");
  // One shape (`shape`) or the shapes drawn among (`shapes`), not both.
  if (f.has("shape") && f.has("shapes"))
    r.fail(f.get("shapes"), f.sub("shapes"), "give `shape` or `shapes`, not both");
  if (const auto n = f.get("shape"); n.IsDefined()) s.shapes = {read_shape(r, n, f.sub("shape"))};
  if (const auto n = f.get("shapes"); n.IsDefined()) {
    r.require_sequence(n, f.sub("shapes"));
    if (n.size() == 0 || n.size() > 4) r.fail(n, f.sub("shapes"), "expected one to four shapes");
    s.shapes.clear();
    for (std::size_t i = 0; i < n.size(); ++i) {
      const LesionShape::Kind k = read_shape(r, n[i], indexed(f.sub("shapes"), i));
      if (std::find(s.shapes.begin(), s.shapes.end(), k) != s.shapes.end())
        r.fail(n[i], indexed(f.sub("shapes"), i),
               fmt::format("shape '{}' listed twice", lesion_kind_name(k)));
      s.shapes.push_back(k);
    }
  }
  return s;
}

// One lesion of a case: {site, severity, size, width, depth, shape, offset}.
CaseLesion read_case_lesion(const Reader& r, const YAML::Node& node, const std::string& path,
                            const std::vector<LesionSite>& sites) {
  const Fields f(r, node, path, {"site", "severity", "size", "width", "depth", "shape", "offset"});
  CaseLesion c;
  c.site = r.text(f.require("site"), f.sub("site"));
  const auto site =
      std::find_if(sites.begin(), sites.end(), [&](const LesionSite& s) { return s.name == c.site; });
  if (site == sites.end()) {
    std::string names;
    for (const auto& s : sites) names += (names.empty() ? "" : ", ") + s.name;
    r.fail(f.get("site"), f.sub("site"), fmt::format("unknown site '{}' (sites: {})", c.site, names));
  }
  c.severity = r.choice(f.require("severity"), f.sub("severity"), "severity", {"mild", "severe"}) == 0
                   ? Grade::Mild
                   : Grade::Severe;
  f.positive("size", c.size, 50.0, "mm");
  f.positive("width", c.width, 50.0, "mm");
  f.positive("depth", c.depth, 20.0, "mm");
  c.shape = site->shapes.front();
  if (const auto n = f.get("shape"); n.IsDefined()) c.shape = read_shape(r, n, f.sub("shape"));
  // The offset: within the site's region.
  if (const auto n = f.get("offset"); n.IsDefined()) {
    r.require_sequence(n, f.sub("offset"));
    if (n.size() != 2) r.fail(n, f.sub("offset"), "expected [along, across] (mm in the site's region)");
    for (std::size_t i = 0; i < 2; ++i)
      c.offset[i] = r.number_in(n[i], indexed(f.sub("offset"), i), -kMaxRegion, kMaxRegion, "mm");
    if (!in_site_region(*site, c.offset))
      r.fail(n, f.sub("offset"),
             fmt::format("[{}, {}] lies outside the region of site '{}' (half-axes [{}, {}] mm)", c.offset[0],
                         c.offset[1], site->name, site->region[0], site->region[1]));
  }
  return c;
}

// `diagnosis.generate`.
CaseGenerator read_generator(const Reader& r, const YAML::Node& node, const std::string& path) {
  const Fields f(r, node, path, {"count", "mild_fraction", "size", "width", "mild_depth", "severe_depth"});
  CaseGenerator g;
  if (const auto n = f.get("count"); n.IsDefined()) {
    r.require_sequence(n, f.sub("count"));
    if (n.size() != 2) r.fail(n, f.sub("count"), "expected [min, max]");
    g.min_count = static_cast<int>(r.integer_in(n[0], indexed(f.sub("count"), 0), 0, 16));
    g.max_count = static_cast<int>(r.integer_in(n[1], indexed(f.sub("count"), 1), 0, 16));
    if (g.min_count > g.max_count) r.fail(n, f.sub("count"), "min is above max");
  }
  f.number_in("mild_fraction", g.mild_fraction, 0.0, 1.0, "");
  if (const auto n = f.get("size"); n.IsDefined())
    read_range(r, n, f.sub("size"), 0.1, 50.0, "mm", g.min_size, g.max_size);
  if (const auto n = f.get("width"); n.IsDefined())
    read_range(r, n, f.sub("width"), 0.1, 50.0, "mm", g.min_width, g.max_width);
  if (const auto n = f.get("mild_depth"); n.IsDefined())
    read_range(r, n, f.sub("mild_depth"), 0.05, 20.0, "mm", g.mild_depth[0], g.mild_depth[1]);
  if (const auto n = f.get("severe_depth"); n.IsDefined())
    read_range(r, n, f.sub("severe_depth"), 0.05, 20.0, "mm", g.severe_depth[0], g.severe_depth[1]);
  return g;
}

// A scene name or file of a study: built-in names as they are, files relative to the study file.
std::string resolve_scene(const std::string& scene, const std::filesystem::path& origin) {
  if (!builtin_scene_yaml(scene).empty()) return scene;
  const std::filesystem::path p(scene);
  if (p.is_absolute() || origin.string().starts_with("builtin:")) return scene;
  return (origin.parent_path() / p).lexically_normal().string();
}

// Loads a study's scene, naming the study field when it fails.
SceneDesc load_study_scene(const Reader& r, const YAML::Node& node, const std::string& path,
                           const std::string& scene) {
  try {
    return load_scene(scene);
  } catch (const Error& e) {
    r.fail(node, path, fmt::format("scene '{}': {}", scene, e.what()));
  }
}

// The `diagnosis` section.
void read_diagnosis(const Reader& r, const YAML::Node& node, const std::string& path,
                    const std::filesystem::path& origin, DiagnosisDesc& d) {
  const Fields f(r, node, path, {"scene", "sites", "cases", "generate", "time_limit", "detection_margin"});
  if (const auto n = f.get("scene"); n.IsDefined()) d.scene = r.text(n, f.sub("scene"));
  d.scene = resolve_scene(d.scene, origin);
  const SceneDesc scene =
      load_study_scene(r, f.has("scene") ? f.get("scene") : node, f.sub("scene"), d.scene);
  f.number_in("time_limit", d.time_limit, 0.0, kMaxTimeLimit, "s");
  f.number_in("detection_margin", d.detection_margin, 0.0, 10.0, "mm");

  const YAML::Node sites = f.require("sites");
  r.require_sequence(sites, f.sub("sites"));
  if (sites.size() == 0) r.fail(sites, f.sub("sites"), "expected at least one site");
  std::set<std::string> names;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    LesionSite s = read_site(r, sites[i], indexed(f.sub("sites"), i), scene);
    if (!names.insert(s.name).second)
      r.fail(sites[i], indexed(f.sub("sites"), i), fmt::format("site '{}' listed twice", s.name));
    d.sites.push_back(std::move(s));
  }
  if (const auto n = f.get("cases"); n.IsDefined()) {
    r.require_sequence(n, f.sub("cases"));
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string case_path = indexed(f.sub("cases"), i);
      const Fields c(r, n[i], case_path, {"lesions"});
      const YAML::Node lesions = c.require("lesions");
      r.require_sequence(lesions, c.sub("lesions"));
      std::vector<CaseLesion> list;
      std::set<std::string> used;
      for (std::size_t k = 0; k < lesions.size(); ++k) {
        CaseLesion l = read_case_lesion(r, lesions[k], indexed(c.sub("lesions"), k), d.sites);
        if (!used.insert(l.site).second)
          r.fail(lesions[k], indexed(c.sub("lesions"), k),
                 fmt::format("site '{}' used twice in one case", l.site));
        list.push_back(std::move(l));
      }
      d.cases.push_back(std::move(list));
    }
  }
  if (const auto n = f.get("generate"); n.IsDefined()) {
    d.generate = read_generator(r, n, f.sub("generate"));
    if (d.generate->min_count > static_cast<int>(d.sites.size()))
      r.fail(
          n, f.sub("generate.count"),
          fmt::format("at least {} lesions asked, but only {} sites", d.generate->min_count, d.sites.size()));
  }
  if (d.cases.empty() && !d.generate) r.fail(node, path, "give `cases`, `generate` or both");
}

// The `scoring` section.
void read_scoring(const Reader& r, const YAML::Node& node, const std::string& path, ScoringDesc& s) {
  const Fields f(r, node, path, {"soft_tissue_threshold", "enamel_force_limit", "blocked_min_duration"});
  if (const auto n = f.get("soft_tissue_threshold"); n.IsDefined())
    s.soft_tissue_threshold = r.positive(n, f.sub("soft_tissue_threshold"), 1000.0, "N");
  f.positive("enamel_force_limit", s.enamel_force_limit, 1000.0, "N");
  f.positive("blocked_min_duration", s.blocked_min_duration, 60.0, "s");
}

// The name of a kind as the study file writes it.
std::string_view kind_key(StudyKind kind) {
  switch (kind) {
    case StudyKind::Tuning:
      return "tuning";
    case StudyKind::Boundary:
      return "boundary";
    case StudyKind::Diagnosis:
      return "diagnosis";
  }
  return "";
}

}  // namespace

std::string_view study_kind_name(StudyKind kind) {
  switch (kind) {
    case StudyKind::Tuning:
      return kKindTuning;
    case StudyKind::Boundary:
      return kKindBoundary;
    case StudyKind::Diagnosis:
      return kKindDiagnosis;
  }
  return "";
}

std::string_view grade_name(Grade grade) { return grade == Grade::Mild ? "mild" : "severe"; }

bool parse_grade(std::string_view text, Grade& out) {
  if (text == "mild") {
    out = Grade::Mild;
    return true;
  }
  if (text == "severe") {
    out = Grade::Severe;
    return true;
  }
  return false;
}

std::vector<std::string> site_kind_names() { return {std::begin(kSiteKinds), std::end(kSiteKinds)}; }

std::array<Vec3, 2> site_axes(const LesionSite& site) {
  // The tangent with its normal part removed (the parser refuses one parallel to the normal).
  const Vec3 along = (site.tangent - site.tangent.dot(site.normal) * site.normal).normalized();
  return {along, site.normal.cross(along)};
}

Vec3 site_point(const LesionSite& site, const std::array<double, 2>& offset) {
  const std::array<Vec3, 2> axes = site_axes(site);
  return site.at + offset[0] * axes[0] + offset[1] * axes[1];
}

bool in_site_region(const LesionSite& site, const std::array<double, 2>& offset) {
  // Inside the ellipse; a zero half-axis takes only a zero offset along it.
  double sum = 0.0;
  for (std::size_t i = 0; i < 2; ++i) {
    if (site.region[i] == 0.0) {
      if (offset[i] != 0.0) return false;
      continue;
    }
    const double q = offset[i] / site.region[i];
    sum += q * q;
  }
  return std::isfinite(sum) && sum <= 1.0;
}

Study parse_study(std::string_view yaml, const std::filesystem::path& origin) {
  const Reader r(origin.string());
  const YAML::Node root = io::parse_document(yaml, origin.string());
  if (!root.IsDefined() || root.IsNull()) throw Error(fmt::format("{}: empty study file", origin.string()));
  const Fields f(r, root, "",
                 {"name", "description", "format", "kind", "trials", "seed", "tuning", "boundary",
                  "diagnosis", "scoring", "debrief"});
  Study s;
  s.origin = origin.string();
  s.source = std::string(yaml);
  s.source_hash = BuildKey().add(s.source).value();
  if (const auto n = f.get("format"); n.IsDefined()) (void)r.integer_in(n, f.sub("format"), 1, 1);
  // The name becomes part of file names (the trials' recordings): the station-name rule.
  if (const auto n = f.get("name"); n.IsDefined()) {
    s.name = r.text(n, f.sub("name"));
    if (!valid_identifier(s.name))
      r.fail(n, f.sub("name"), fmt::format("'{}' is not a valid study name: {}", s.name, kIdentifierRule));
  } else {
    const std::string o = origin.string();
    s.name = o.starts_with("builtin:") ? o.substr(8) : origin.stem().string();
    if (!valid_identifier(s.name))
      throw Error(
          fmt::format("{}: name: the file's name '{}' is not a valid study name ({}); give the study "
                      "a `name:`",
                      origin.string(), s.name, kIdentifierRule));
  }
  if (const auto n = f.get("description"); n.IsDefined()) s.description = r.text(n, f.sub("description"));
  const std::size_t kind =
      r.choice(f.require("kind"), f.sub("kind"), "study kind", {kKindTuning, kKindBoundary, kKindDiagnosis});
  s.kind = static_cast<StudyKind>(kind);
  if (const auto n = f.get("trials"); n.IsDefined())
    s.trials = static_cast<int>(r.integer_in(n, f.sub("trials"), 1, kMaxTrials));
  if (const auto n = f.get("seed"); n.IsDefined()) {
    s.seed = parse_seed(r.text(n, f.sub("seed")));
    if (!s.seed) r.fail(n, f.sub("seed"), fmt::format("expected an integer in [0, {}]", kMaxSeed));
  }

  // Only the section of the study's kind may be there, and it must be for tuning and diagnosis.
  for (const StudyKind other : {StudyKind::Tuning, StudyKind::Boundary, StudyKind::Diagnosis}) {
    if (other != s.kind && f.has(kind_key(other))) {
      r.fail(f.get(kind_key(other)), f.sub(kind_key(other)),
             fmt::format("a {} study has no `{}` section", study_kind_name(s.kind), kind_key(other)));
    }
  }
  switch (s.kind) {
    case StudyKind::Tuning: {
      const YAML::Node n = f.require("tuning");
      read_tuning(r, n, f.sub("tuning"), s.tuning);
      if (s.tuning.scene.empty())
        s.tuning.scene = s.tuning.target == TuningTarget::Roughness ? "friction-block" : "insertion-blocks";
      s.tuning.scene = resolve_scene(s.tuning.scene, origin);
      const SceneDesc scene = load_study_scene(r, n, f.sub("tuning.scene"), s.tuning.scene);
      if (scene.lesions.empty())
        r.fail(n, f.sub("tuning.scene"), fmt::format("scene {} has no lesion", scene.name));
      if (s.tuning.lesion.empty()) s.tuning.lesion = scene.lesions.front().name;
      if (std::none_of(scene.lesions.begin(), scene.lesions.end(),
                       [&](const LesionDesc& l) { return l.name == s.tuning.lesion; }))
        r.fail(n, f.sub("tuning.lesion"),
               fmt::format("no lesion '{}' in scene {}", s.tuning.lesion, scene.name));
      break;
    }
    case StudyKind::Boundary:
      if (const auto n = f.get("boundary"); n.IsDefined()) read_boundary(r, n, f.sub("boundary"), s.boundary);
      break;
    case StudyKind::Diagnosis:
      read_diagnosis(r, f.require("diagnosis"), f.sub("diagnosis"), origin, s.diagnosis);
      break;
  }
  if (const auto n = f.get("scoring"); n.IsDefined()) read_scoring(r, n, f.sub("scoring"), s.scoring);
  // When a trainee sees the debrief (docs/training.md): only a diagnosis case has one.
  if (const auto n = f.get("debrief"); n.IsDefined()) {
    s.debrief = static_cast<DebriefWhen>(
        r.choice(n, f.sub("debrief"), "debrief", {"after-each-case", "at-end", "never"}));
    if (s.kind != StudyKind::Diagnosis && s.debrief != DebriefWhen::Never)
      r.fail(n, f.sub("debrief"),
             fmt::format("a {} study has no debrief (only a diagnosis study's cases do)",
                         study_kind_name(s.kind)));
  }
  return s;
}

Study load_study(const std::string& name_or_file) {
  // A built-in study by name, else a file.
  const io::NamedText source =
      io::builtin_or_file(name_or_file, "study", builtin_study_yaml(name_or_file), builtin_study_names());
  return parse_study(source.text, source.origin);
}

std::vector<std::string> builtin_study_names() {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < kBuiltinStudyCount; ++i) names.emplace_back(kBuiltinStudies[i].name);
  return names;
}

std::string_view builtin_study_yaml(std::string_view name) {
  for (std::size_t i = 0; i < kBuiltinStudyCount; ++i)
    if (kBuiltinStudies[i].name == name) return kBuiltinStudies[i].yaml;
  return {};
}

std::optional<uint64_t> parse_seed(std::string_view text) {
  // Decimal digits only (at most 19: kMaxSeed has 19), the whole text used, then the range.
  if (text.empty() || text.size() > 19 ||
      !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  uint64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value, 10);
  if (ec != std::errc() || end != text.data() + text.size() || value > kMaxSeed) return std::nullopt;
  return value;
}

uint64_t trial_seed(uint64_t study_seed, int index) {
  // The (index+1)-th output of the study's stream, its top 63 bits (docs/training.md, "seeds"), so
  // it fits SQLite's signed INTEGER.
  std::mt19937_64 stream(study_seed);
  stream.discard(static_cast<unsigned long long>(index));
  return stream() >> 1;
}

uint64_t participant_seed(uint64_t study_seed, std::string_view participant) {
  // std::seed_seq's and std::mt19937_64's seeding are fixed by the standard, so this is the same on
  // every machine (docs/training.md, "seeds").
  std::vector<uint32_t> words{static_cast<uint32_t>(study_seed & 0xffffffffu),
                              static_cast<uint32_t>(study_seed >> 32),
                              static_cast<uint32_t>(participant.size())};
  for (const char c : participant) words.push_back(static_cast<unsigned char>(c));
  std::seed_seq seq(words.begin(), words.end());
  std::mt19937_64 stream(seq);
  return stream() >> 1;
}

SceneDesc TrialSetup::scene() const { return parse_scene(scene_yaml, scene_origin); }

}  // namespace cariesim::training
