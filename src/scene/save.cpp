// Saving lesion materials back into a scene file (the viewer's sliders, docs/viewer.md): load the
// YAML with yaml-cpp, set each edited lesion's `material` fields, emit, and check the result parses.

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>

#include "cariesim/common/error.hpp"
#include "cariesim/io/yaml.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {

namespace {

// A number as a plain YAML scalar: six significant digits, no trailing noise from sliders.
std::string number(double v) { return fmt::format("{:.6g}", v); }

// A k_c profile in the scene format: a number, {layers: [...]} or {gradient: {...}}.
YAML::Node kc_node(const KcProfile& k) {
  YAML::Node node;
  switch (k.kind) {
    case KcProfile::Kind::Constant:
      node = number(k.values[0]);
      break;
    case KcProfile::Kind::Layers:
      for (int i = 0; i < k.layer_count && i < KcProfile::kMaxLayers; ++i) {
        YAML::Node layer;
        layer["to"] = number(k.bounds[i]);
        layer["k_c"] = number(k.values[i]);
        node["layers"].push_back(layer);
      }
      break;
    case KcProfile::Kind::Gradient:
      node["gradient"]["top"] = number(k.values[0]);
      node["gradient"]["bottom"] = number(k.values[1]);
      node["gradient"]["to"] = number(k.bounds[0]);
      break;
  }
  return node;
}

// Sets the material fields of one lesion entry.
void set_material(YAML::Node lesion, const Material& m) {
  YAML::Node mat = lesion["material"];
  if (!mat.IsMap()) mat = YAML::Node(YAML::NodeType::Map);
  mat["k_e"] = number(m.k_e);
  mat["stiffness"] = std::isfinite(m.stiffness) ? number(m.stiffness) : std::string("rigid");
  mat["mu_s"] = number(m.mu_s);
  mat["mu_d"] = number(m.mu_d);
  mat["k_c"] = kc_node(m.k_c);
  mat["crush_length"] = number(m.crush_length);
  mat["f_p_star"] = number(m.f_p_star);
  mat["f_e_star"] = number(m.f_e_star);
  mat["k_theta"] = number(m.k_theta);
  if (m.aniso_dir.isZero() && mat["anisotropic"].IsDefined()) mat.remove("anisotropic");
  lesion["material"] = mat;
}

}  // namespace

std::string set_lesion_materials(std::string_view yaml, const std::filesystem::path& origin,
                                 const std::vector<LesionMaterialEdit>& edits) {
  // Parse the document as it is (one strict document: io::parse_document).
  YAML::Node root = io::parse_document(yaml, origin.string());
  const YAML::Node lesions = root.IsMap() ? root["lesions"] : YAML::Node();
  // Each edit goes to the lesion of its name.
  for (const LesionMaterialEdit& edit : edits) {
    bool found = false;
    for (std::size_t i = 0; lesions.IsSequence() && i < lesions.size(); ++i) {
      YAML::Node entry = lesions[i];
      if (!entry.IsMap() || !entry["name"].IsScalar() || entry["name"].Scalar() != edit.lesion) continue;
      set_material(entry, edit.material);
      found = true;
      break;
    }
    if (!found) throw Error(fmt::format("{}: no lesion named '{}' to save", origin.string(), edit.lesion));
  }
  // Emit and make sure the result is still a valid scene.
  YAML::Emitter out;
  out << root;
  if (!out.good())
    throw Error(fmt::format("{}: cannot write the scene: {}", origin.string(), out.GetLastError()));
  std::string text = std::string(out.c_str()) + "\n";
  parse_scene(text, origin);
  return text;
}

std::filesystem::path save_lesion_materials(const std::string& source, const std::filesystem::path& target,
                                            const std::vector<LesionMaterialEdit>& edits) {
  // The source text: a built-in scene or a file.
  const io::NamedText text =
      io::builtin_or_file(source, "scene", builtin_scene_yaml(source), builtin_scene_names());
  const std::filesystem::path origin = text.builtin ? target : text.origin;
  const std::string edited = set_lesion_materials(text.text, origin, edits);

  // Keep what `target` held as target.bak, then write through a temporary file and rename it.
  std::error_code ec;
  std::filesystem::path backup;
  if (std::filesystem::exists(target, ec)) {
    backup = target;
    backup += ".bak";
    std::filesystem::copy_file(target, backup, std::filesystem::copy_options::overwrite_existing, ec);
    if (ec) throw Error(fmt::format("{}: cannot keep a backup: {}", backup.string(), ec.message()));
  }
  std::filesystem::path temporary = target;
  temporary += ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out.is_open()) throw Error(fmt::format("{}: cannot write the file", temporary.string()));
    out << edited;
    out.close();
    if (!out) throw Error(fmt::format("{}: writing failed", temporary.string()));
  }
  std::filesystem::rename(temporary, target, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    throw Error(fmt::format("{}: cannot replace the file", target.string()));
  }
  return backup;
}

}  // namespace cariesim
