#pragma once
/// Scenes: YAML files (yaml-cpp) and built-in scenes (DESIGN.md §6), and building a Model from them.
/// The format is documented in docs/scene-format.md.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cariesim/common/progress.hpp"
#include "cariesim/render/model.hpp"
#include "cariesim/scene/scene_desc.hpp"
#include "cariesim/spheretree/build.hpp"

namespace cariesim {

/// Parses scene YAML. `origin` names the text in messages and anchors relative mesh paths.
/// Throws cariesim::Error with "file:line:column: message" on any problem (wrong type, missing
/// field, unknown key, out-of-range value).
SceneDesc parse_scene(std::string_view yaml, const std::filesystem::path& origin);

/// A built-in scene name ("oral-cavity", "friction-block", ...) or a path to a YAML file.
SceneDesc load_scene(const std::string& name_or_file);

/// Names of the built-in scenes, the default ("oral-cavity") first.
std::vector<std::string> builtin_scene_names();
/// The YAML text of a built-in scene; empty when there is none of that name.
std::string_view builtin_scene_yaml(std::string_view name);

struct BuildOptions {
  bool use_cache = true;                 ///< read and write the tree cache
  std::optional<TreeMode> mode;          ///< overrides every object's tree mode
  std::optional<int> octree_depth;       ///< overrides the octree depth
  std::optional<double> tolerance;       ///< mm, overrides the tight tolerance
  ProgressFn progress;                   ///< long builds report here
};

/// Builds the engine's Model: meshes or procedural shapes, level sets, CSG with the lesions
/// (healthy = tooth - lesion, caries = tooth ∩ lesion), sphere trees (cached), materials, the tool.
Model build_model(const SceneDesc& scene, const BuildOptions& options = {});

}  // namespace cariesim
