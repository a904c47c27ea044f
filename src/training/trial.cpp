// Making a trial from its seed (docs/training.md, "seeds"): the draws in their documented order, and
// the trial's scene as YAML text (the tuning scene with the sliders' start values, three boundary cubes,
// the diagnosis scene with the case's lesions in place of its own).

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "cariesim/common/error.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/training/study.hpp"
#include "training/draws.hpp"
#include "training/study_schema.hpp"

namespace cariesim::training {

namespace {

// The text of a scene (built-in or file) and the origin parse_scene should name it by.
std::pair<std::string, std::string> scene_text(const std::string& scene) {
  io::NamedText source =
      io::builtin_or_file(scene, "scene", builtin_scene_yaml(scene), builtin_scene_names());
  return {std::move(source.text), source.origin.string()};
}

// "[x, y, z]" with the shortest exact decimal of each coordinate.
std::string vec_text(const Vec3& v) { return fmt::format("[{}, {}, {}]", v.x(), v.y(), v.z()); }

// Tuning: the levels in a drawn order, then each slider's start (draws 1 and 2 of docs/training.md).
void make_tuning(const Study& study, Draws& draws, TrialSetup& t) {
  t.levels = study.tuning.levels;
  draws.shuffle(t.levels);
  t.parameters = study.tuning.parameters;
  // Starts are rounded to 1e-4 (a slider's resolution), so the scene text holds them exactly.
  for (TunedParameter& p : t.parameters)
    p.start = std::clamp(std::round(draws.uniform(p.min, p.max) * 1e4) / 1e4, p.min, p.max);
  t.tuned_lesion = study.tuning.lesion;

  // The scene with the tuned lesion's material at the sliders' start values.
  const auto [yaml, origin] = scene_text(study.tuning.scene);
  const SceneDesc scene = parse_scene(yaml, origin);
  const auto it = std::find_if(scene.lesions.begin(), scene.lesions.end(),
                               [&](const LesionDesc& l) { return l.name == study.tuning.lesion; });
  if (it == scene.lesions.end())
    throw Error(fmt::format("{}: no lesion '{}' in scene {}", study.origin, study.tuning.lesion, scene.name));
  LesionMaterialEdit edit{it->name, it->material};
  for (const TunedParameter& p : t.parameters) {
    if (p.name == kScoreMuS) edit.material.mu_s = p.start;
    if (p.name == kScoreMuD) edit.material.mu_d = p.start;
    if (p.name == kScoreKe) edit.material.k_e = p.start;
    if (p.name == kScoreKc) {
      edit.material.k_c = KcProfile{};
      edit.material.k_c.values[0] = p.start;
    }
  }
  t.scene_yaml = set_lesion_materials(yaml, origin, {edit});
  t.scene_origin = origin;
}

// Boundary: the shapes in a drawn order (one draw sequence of docs/training.md), one cube each.
void make_boundary(const Study& study, Draws& draws, TrialSetup& t) {
  const BoundaryDesc& b = study.boundary;
  t.truth.shapes = b.shapes;
  draws.shuffle(t.truth.shapes);
  t.shape_choices = b.shapes;
  std::sort(t.shape_choices.begin(), t.shape_choices.end());
  t.shape_choices.erase(std::unique(t.shape_choices.begin(), t.shape_choices.end()), t.shape_choices.end());

  // Identical cubes along x, centred on x = 0, their tops at z = 0; the shape under each top.
  const std::size_t n = t.truth.shapes.size();
  const double first_x = -0.5 * b.spacing * static_cast<double>(n - 1);
  const double max_radius = std::min(8.0, 0.4 * b.cube.z());
  std::string yaml = fmt::format(
      "# {} trial {}: {} cubes hiding shapes in a drawn order (docs/training.md).\n"
      "name: {}-trial{}\ndescription: Boundary shapes study cubes (paper section 4.2.2).\nformat: "
      "1\n\nobjects:\n",
      study.name, t.index + 1, n, study.name, t.index + 1);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string name = fmt::format("cube{}", i + 1);
    t.cubes.push_back(name);
    yaml += fmt::format(
        "  - name: {}\n    shape: {{type: cuboid, size: {}}}\n    pose: {{position: [{}, 0.0, 0.0]}}\n"
        "    tissue: generic\n    material: {{stiffness: {}}}\n"
        "    tree: {{mode: tight, tolerance: 0.1, max_radius: {}, min_radius: 0.3}}\n",
        name, vec_text(b.cube), first_x + b.spacing * static_cast<double>(i), b.stiffness, max_radius);
  }
  yaml += "\nlesions:\n";
  for (std::size_t i = 0; i < n; ++i) {
    yaml += fmt::format(
        "  - name: hidden{}\n    object: cube{}\n"
        "    placement: {{at: [0.0, 0.0, 0.0], normal: [0, 0, 1], tangent: [1, 0, 0], snap: false}}\n"
        "    shape: {{type: {}, size: {}, depth: {}}}\n"
        "    material: {{stiffness: {}, k_e: 1.0, mu_s: {}, mu_d: {}, f_p_star: 15.0}}\n",
        i + 1, i + 1, t.truth.shapes[i], b.shape_size, b.depth, b.stiffness, b.mu_s, b.mu_d);
  }
  // The tool above the first cube's near corner, the tip lowest, the handle rising toward +x.
  yaml += fmt::format(
      "\ntool:\n  home: {{position: [{}, {}, 10.0], rotation: {{axis: [0, 1, 0], angle: -50}}}}\n",
      first_x - 0.45 * b.cube.x(), -0.45 * b.cube.y());
  t.scene_yaml = std::move(yaml);
  t.scene_origin = fmt::format("{}#trial{}", study.origin, t.index + 1);
}

// Two sites too close for one case: their regions, grown by half the largest lesion and the detection
// margin each, meet (so no mark can be within the margin of both lesions).
bool too_close(const LesionSite& a, const LesionSite& b, const CaseGenerator& g, double margin) {
  const double reach = std::max(a.region[0], a.region[1]) + std::max(b.region[0], b.region[1]) +
                       std::max(g.max_size, g.max_width) + 2.0 * margin;
  return (a.world_at - b.world_at).norm() < reach;
}

// Where a drawn lesion lies in its site's region: a point drawn uniformly in the unit disk (pairs
// drawn in the square until one falls inside; after 64 misses, the centre), scaled by the half-axes.
std::array<double, 2> draw_offset(const LesionSite& site, Draws& draws) {
  for (int tries = 0; tries < 64; ++tries) {
    const double u = draws.uniform(-1.0, 1.0);
    const double v = draws.uniform(-1.0, 1.0);
    if (u * u + v * v <= 1.0) return {u * site.region[0], v * site.region[1]};
  }
  return {0.0, 0.0};
}

// A drawn case (docs/training.md): the count, the sites (apart from each other), then per lesion
// severity, size, width, depth, shape and place in its site's region.
std::vector<CaseLesion> draw_case(const DiagnosisDesc& d, const CaseGenerator& g, Draws& draws) {
  const int max_count = std::min<int>(g.max_count, static_cast<int>(d.sites.size()));
  const int min_count = std::min(g.min_count, max_count);
  const int count =
      min_count + static_cast<int>(draws.index(static_cast<std::size_t>(max_count - min_count + 1)));
  std::vector<std::size_t> order(d.sites.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  draws.shuffle(order);
  std::vector<const LesionSite*> taken;
  for (const std::size_t i : order) {
    if (static_cast<int>(taken.size()) == count) break;
    const LesionSite& site = d.sites[i];
    if (std::none_of(taken.begin(), taken.end(),
                     [&](const LesionSite* t) { return too_close(*t, site, g, d.detection_margin); }))
      taken.push_back(&site);
  }
  std::vector<CaseLesion> lesions;
  for (const LesionSite* site : taken) {
    CaseLesion c;
    c.site = site->name;
    c.severity = draws.uniform(0.0, 1.0) < g.mild_fraction ? Grade::Mild : Grade::Severe;
    c.size = draws.uniform(g.min_size, g.max_size);
    c.width = draws.uniform(g.min_width, g.max_width);
    const double* depth = c.severity == Grade::Mild ? g.mild_depth : g.severe_depth;
    c.depth = draws.uniform(depth[0], depth[1]);
    c.shape = site->shapes[draws.index(site->shapes.size())];
    c.offset = draw_offset(*site, draws);
    lesions.push_back(c);
  }
  return lesions;
}

// Diagnosis: the case (listed or drawn) hidden in the scene in place of its own lesions.
void make_diagnosis(const Study& study, Draws& draws, TrialSetup& t) {
  const DiagnosisDesc& d = study.diagnosis;
  const auto index = static_cast<std::size_t>(t.index);
  if (index < d.cases.size() || !d.generate) {
    t.truth.lesions = d.cases[index % d.cases.size()];
  } else {
    t.truth.lesions = draw_case(d, *d.generate, draws);
  }
  t.time_limit = d.time_limit;

  const auto [yaml, origin] = scene_text(d.scene);
  YAML::Node root = io::parse_document(yaml, origin);
  YAML::Node lesions(YAML::NodeType::Sequence);
  for (std::size_t k = 0; k < t.truth.lesions.size(); ++k) {
    const CaseLesion& c = t.truth.lesions[k];
    const auto site =
        std::find_if(d.sites.begin(), d.sites.end(), [&](const LesionSite& s) { return s.name == c.site; });
    if (site == d.sites.end())
      throw Error(fmt::format("{}: case lesion at unknown site '{}'", study.origin, c.site));
    YAML::Node l;
    l["name"] = fmt::format("lesion{}", k + 1);
    l["object"] = site->object;
    YAML::Node placement;
    for (const auto& [key, v] : {std::pair{"at", site_point(*site, c.offset)},
                                 {"normal", site->normal},
                                 {"tangent", site->tangent}}) {
      YAML::Node seq(YAML::NodeType::Sequence);
      for (int i = 0; i < 3; ++i) seq.push_back(v[i]);
      seq.SetStyle(YAML::EmitterStyle::Flow);
      placement[key] = seq;
    }
    placement["snap_range"] = site->snap_range;
    placement.SetStyle(YAML::EmitterStyle::Flow);
    l["placement"] = placement;
    YAML::Node shape;
    shape["type"] = std::string(lesion_kind_name(c.shape));
    shape["size"] = c.size;
    if (c.shape == LesionShape::Kind::Stripe || c.shape == LesionShape::Kind::Ellipsoid)
      shape["width"] = c.width;
    shape["depth"] = c.depth;
    shape.SetStyle(YAML::EmitterStyle::Flow);
    l["shape"] = shape;
    l["severity"] = std::string(grade_name(c.severity));
    lesions.push_back(l);
  }
  if (lesions.size() == 0) {
    root.remove("lesions");
  } else {
    root["lesions"] = lesions;
  }
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << root;
  t.scene_yaml = fmt::format("# {} trial {}: scene {} with the case's lesions (docs/training.md).\n{}\n",
                             study.name, t.index + 1, d.scene, out.c_str());
  t.scene_origin = origin;
}

}  // namespace

TrialSetup make_trial(const Study& study, int index, uint64_t seed) {
  TrialSetup t;
  t.index = index;
  t.kind = study.kind;
  t.seed = seed;
  Draws draws(seed);
  switch (study.kind) {
    case StudyKind::Tuning:
      make_tuning(study, draws, t);
      break;
    case StudyKind::Boundary:
      make_boundary(study, draws, t);
      break;
    case StudyKind::Diagnosis:
      make_diagnosis(study, draws, t);
      break;
  }
  // The scene must parse: a bad trial is reported here, naming the study, not when it is loaded.
  try {
    (void)t.scene();
  } catch (const Error& e) {
    throw Error(fmt::format("{}: trial {}: its scene is not valid: {}", study.origin, index + 1, e.what()));
  }
  return t;
}

}  // namespace cariesim::training
