// Scenes, models and Params for Python (docs/python.md): a scene loaded with overrides (the same
// parse_scene as `cariesim scene check`), built with the tree cache and an optional progress callback
// (the GIL released), the trees as arrays, and the running parameters with the sliders' rules.

#include "cariesim/scene/scene.hpp"

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "cariesim/common/error.hpp"
#include "cariesim/render/params.hpp"
#include "cariesim/scene/model_builder.hpp"

namespace py = pybind11;

namespace cariesim::python {

namespace {

// The ParamChange fields by the names the scene format gives them.
struct FieldName {
  const char* name;
  ParamChange::Field field;
};
constexpr FieldName kFields[] = {
    {"mu_s", ParamChange::Field::MuS},
    {"mu_d", ParamChange::Field::MuD},
    {"stiffness", ParamChange::Field::Stiffness},
    {"k_e", ParamChange::Field::KE},
    {"k_c", ParamChange::Field::KC},
    {"f_p_star", ParamChange::Field::FPStar},
    {"f_e_star", ParamChange::Field::FEStar},
    {"k_theta", ParamChange::Field::KTheta},
    {"preset", ParamChange::Field::Preset},
};

ParamChange::Field field_of(const std::string& name) {
  std::string known;
  for (const FieldName& f : kFields) {
    if (name == f.name) return f.field;
    known += (known.empty() ? "" : ", ") + std::string(f.name);
  }
  throw Error("params: unknown field '" + name + "' (fields: " + known + ")");
}

// A material as a dict of its scene-format fields (units in docs/scene-format.md).
py::dict material_dict(const Material& m) {
  py::dict d;
  d["tissue"] = std::string(tissue_name(m.tissue));
  d["lesion"] = m.lesion;
  d["stiffness"] = m.stiffness;  // N/mm, inf = rigid
  d["mu_s"] = m.mu_s;
  d["mu_d"] = m.mu_d;
  d["k_e"] = m.k_e;  // N/mm
  if (m.k_c.kind == KcProfile::Kind::Constant) {
    d["k_c"] = m.k_c.values[0];  // N/mm
  } else {
    py::dict k;
    k["kind"] = m.k_c.kind == KcProfile::Kind::Layers ? "layers" : "gradient";
    k["values"] =
        std::vector<double>(m.k_c.values.begin(), m.k_c.values.begin() + std::max(2, m.k_c.layer_count));
    k["bounds"] = std::vector<double>(m.k_c.bounds.begin(), m.k_c.bounds.begin() + m.k_c.layer_count);
    d["k_c"] = k;
  }
  d["crush_length"] = m.crush_length;  // mm
  d["f_p_star"] = m.f_p_star;          // N
  d["f_e_star"] = m.f_e_star;          // N
  d["k_theta"] = m.k_theta;            // N·mm/rad
  return d;
}

// The value of one field of a lesion's first material.
double get_field(const Params& params, int lesion, const std::string& name) {
  const ParamChange::Field field = field_of(name);
  for (const Material& m : params.materials) {
    if (m.lesion != lesion) continue;
    switch (field) {
      case ParamChange::Field::MuS:
        return m.mu_s;
      case ParamChange::Field::MuD:
        return m.mu_d;
      case ParamChange::Field::Stiffness:
        return m.stiffness;
      case ParamChange::Field::KE:
        return m.k_e;
      case ParamChange::Field::KC:
        return m.k_c.values[0];
      case ParamChange::Field::FPStar:
        return m.f_p_star;
      case ParamChange::Field::FEStar:
        return m.f_e_star;
      case ParamChange::Field::KTheta:
        return m.k_theta;
      default:
        break;
    }
    throw Error("params: '" + name + "' is not readable (it is an action)");
  }
  throw Error("params: no lesion " + std::to_string(lesion) + " in this model");
}

// Applies one change through apply_param_change (the sliders' rules); a refusal names the rule.
void set_field(Params& params, int lesion, const std::string& name, double value) {
  const ParamChange::Field field = field_of(name);
  if (lesion < 0 || lesion > std::numeric_limits<int16_t>::max())
    throw Error("params: lesion " + std::to_string(lesion) + " is not a lesion index");
  const ParamChange change{field, static_cast<int16_t>(lesion), value};
  if (apply_param_change(params, change)) return;
  // Refused: say why, with the rule check_material gives the value on a copy.
  const Material* found = nullptr;
  for (const Material& m : params.materials)
    if (m.lesion == lesion) found = &m;
  if (found == nullptr) throw Error("params: no lesion " + std::to_string(lesion) + " in this model");
  Material m = *found;
  switch (field) {
    case ParamChange::Field::MuS:
      m.mu_s = value;
      break;
    case ParamChange::Field::MuD:
      m.mu_d = value;
      break;
    case ParamChange::Field::Stiffness:
      m.stiffness = value;
      break;
    case ParamChange::Field::KE:
      m.k_e = value;
      break;
    case ParamChange::Field::KC:
      m.k_c = KcProfile{};
      m.k_c.values.fill(value);
      break;
    case ParamChange::Field::FPStar:
      m.f_p_star = value;
      break;
    case ParamChange::Field::FEStar:
      m.f_e_star = value;
      break;
    case ParamChange::Field::KTheta:
      m.k_theta = value;
      break;
    default:
      break;
  }
  const ParamProblem problem = check_material(m);
  throw Error(
      "params: lesion " + std::to_string(lesion) + ": " + name + " = " +
      py::str(py::float_(value)).cast<std::string>() + " refused: " +
      (problem ? std::string(problem.field) + ": " + problem.rule : std::string("not a valid value")));
}

// The overrides from Python's (key, value) pairs.
std::vector<SceneOverride> overrides_of(const std::vector<std::pair<std::string, std::string>>& pairs) {
  std::vector<SceneOverride> out;
  for (const auto& [key, value] : pairs) out.push_back(SceneOverride{key, value});
  return out;
}

// One model's sphere trees: per object, its leaves' centres (mm), radii (mm), material and tissue.
py::list trees_of(const Model& model) {
  py::list out;
  for (const CollisionObject& object : model.objects) {
    const SphereTree& tree = object.tree;
    const auto n = static_cast<py::ssize_t>(tree.leaf_count());
    py::array_t<double> centres({n, py::ssize_t{3}});
    py::array_t<double> radii(n);
    py::array_t<int32_t> material(n);
    py::array_t<int32_t> tissue(n);
    auto c = centres.mutable_unchecked<2>();
    auto r = radii.mutable_unchecked<1>();
    auto mat = material.mutable_unchecked<1>();
    auto tis = tissue.mutable_unchecked<1>();
    for (py::ssize_t i = 0; i < n; ++i) {
      const SphereNode& node = tree.nodes[tree.leaf_nodes[static_cast<std::size_t>(i)]];
      for (int k = 0; k < 3; ++k) c(i, k) = node.center[k];
      r(i) = node.radius;
      mat(i) = node.material;
      tis(i) = node.material < model.defaults.materials.size()
                   ? static_cast<int32_t>(model.defaults.materials[node.material].tissue)
                   : -1;
    }
    py::dict d;
    d["name"] = object.name;
    d["lesion"] = object.lesion;
    d["centres"] = centres;
    d["radii"] = radii;
    d["material"] = material;
    d["tissue"] = tissue;
    out.append(d);
  }
  return out;
}

}  // namespace

void bind_scene(py::module_& m) {
  m.def(
      "parse_override",
      [](const std::string& text) {
        const SceneOverride o = parse_override(text);
        return std::make_pair(o.key, o.value);
      },
      "Reads 'KEY=VALUE' as (key, value); raises cariesim.Error for a malformed key.");
  m.def("builtin_scene_names", &builtin_scene_names, "The built-in scenes' names, the default first.");
  m.def(
      "tissue_names",
      [] {
        std::vector<std::string> names;
        for (int t = 0; t <= static_cast<int>(Tissue::Generic); ++t)
          names.emplace_back(tissue_name(static_cast<Tissue>(t)));
        return names;
      },
      "Tissue names by code (the `tissue` arrays of Model.trees()).");

  py::class_<Params>(m, "Params",
                     "The step's running parameters: materials, gains, limits (render/params.hpp).")
      .def_property_readonly(
          "materials",
          [](const Params& p) {
            py::list out;
            for (const Material& mat : p.materials) out.append(material_dict(mat));
            return out;
          },
          "Every material as a dict (scene-format names and units).")
      .def("get", &get_field, py::arg("lesion"), py::arg("field"),
           "A lesion's value: mu_s, mu_d, stiffness, k_e, k_c (N/mm), f_p_star, f_e_star (N), k_theta.")
      .def("set", &set_field, py::arg("lesion"), py::arg("field"), py::arg("value"),
           "Sets a lesion's value with the sliders' rules (apply_param_change); raises cariesim.Error "
           "naming the rule when refused. field 'preset': 0 mild, 1 severe.")
      .def_property_readonly("gains",
                             [](const Params& p) {
                               py::dict d;
                               d["k_trans"] = p.gains.k_trans;  // N/mm
                               d["k_rot"] = p.gains.k_rot;      // N·mm/rad
                               return d;
                             })
      .def_property_readonly("limits",
                             [](const Params& p) {
                               py::dict d;
                               d["max_force"] = p.limits.max_force;          // N
                               d["max_stiffness"] = p.limits.max_stiffness;  // N/mm
                               d["max_torque"] = p.limits.max_torque;        // N·mm
                               return d;
                             })
      .def("copy", [](const Params& p) { return Params(p); });

  py::class_<SceneDesc, std::shared_ptr<SceneDesc>>(m, "SceneDesc", "A parsed, validated scene.")
      .def_readonly("name", &SceneDesc::name)
      .def_readonly("origin", &SceneDesc::origin)
      .def_readonly("description", &SceneDesc::description)
      .def_readonly("servo_rate", &SceneDesc::servo_rate)
      .def_readonly("source_hash", &SceneDesc::source_hash)
      .def_property_readonly("object_names",
                             [](const SceneDesc& s) {
                               std::vector<std::string> names;
                               for (const ObjectDesc& o : s.objects) names.push_back(o.name);
                               return names;
                             })
      .def_property_readonly("lesion_names",
                             [](const SceneDesc& s) {
                               std::vector<std::string> names;
                               for (const LesionDesc& l : s.lesions) names.push_back(l.name);
                               return names;
                             })
      .def_property_readonly("lesion_materials", [](const SceneDesc& s) {
        py::list out;
        for (const LesionDesc& l : s.lesions) out.append(material_dict(l.material));
        return out;
      });

  m.def(
      "load_scene_desc",
      [](const std::string& source, const std::vector<std::pair<std::string, std::string>>& pairs) {
        const std::vector<SceneOverride> overrides = overrides_of(pairs);
        return std::make_shared<SceneDesc>(load_scene(source, overrides));
      },
      py::arg("source"), py::arg("overrides"),
      "A built-in scene or a YAML file, with (key, value) overrides.");

  py::class_<BuiltModel, std::shared_ptr<BuiltModel>>(m, "Model", "A built model (immutable).")
      .def_property_readonly("servo_rate", [](const BuiltModel& b) { return b.model.servo_rate; })
      .def_property_readonly("scene_name", [](const BuiltModel& b) { return b.model.scene_name; })
      .def_property_readonly("scene_hash", [](const BuiltModel& b) { return b.model.scene_hash; })
      .def_property_readonly("lesion_count", [](const BuiltModel& b) { return b.model.lesions.size(); })
      .def_property_readonly(
          "tip_radius", [](const BuiltModel& b) { return b.model.tool.tip_radius; },
          "mm, the explorer's tip sphere (the tool frame's origin is its centre).")
      .def_property_readonly(
          "tool_home",
          [](const BuiltModel& b) {
            const Pose& p = b.model.tool_home;
            return std::vector<double>{p.p.x(), p.p.y(), p.p.z(), p.q.w(), p.q.x(), p.q.y(), p.q.z()};
          },
          "The tool's home pose: px py pz (mm), qw qx qy qz.")
      .def_property_readonly(
          "defaults", [](const BuiltModel& b) { return b.model.defaults; }, "A copy of the authored Params.")
      .def(
          "trees", [](const BuiltModel& b) { return trees_of(b.model); },
          "Per collision object: name, lesion, and its leaves' centres (N×3, mm), radii (mm), "
          "material index and tissue code.")
      .def_property_readonly(
          "parts",
          [](const BuiltModel& b) {
            py::list out;
            for (const PartReport& p : b.report.parts) {
              py::dict d;
              d["name"] = p.name;
              d["leaves"] = p.leaves;
              d["levels"] = p.levels;
              d["build_seconds"] = p.build_seconds;
              d["cache_hit"] = p.cache_hit;
              if (p.deviation) {
                d["deviation_p50"] = p.deviation->p50;  // mm
                d["deviation_p95"] = p.deviation->p95;  // mm
                d["deviation_max"] = p.deviation->max;  // mm
              }
              out.append(d);
            }
            return out;
          },
          "What building each part took; the surface deviation (mm) when measured.");

  m.def(
      "build_model",
      [](const SceneDesc& scene, const std::function<void(std::string, double)>& progress, bool use_cache,
         const std::string& cache_dir, bool measure_deviation) {
        BuildOptions options;
        options.use_cache = use_cache;
        options.cache_dir = cache_dir;
        options.measure_deviation = measure_deviation;
        if (progress) {
          // Called from the building thread: the callback takes the GIL for its own call only.
          options.progress = [&progress](std::string_view stage, double fraction) {
            py::gil_scoped_acquire gil;
            progress(std::string(stage), fraction);
          };
        }
        auto built = std::make_shared<BuiltModel>();
        {
          py::gil_scoped_release release;
          built->model = build_model(scene, options, &built->report);
        }
        return built;
      },
      py::arg("scene"), py::arg("progress"), py::arg("use_cache"), py::arg("cache_dir"),
      py::arg("measure_deviation"));
}

}  // namespace cariesim::python
