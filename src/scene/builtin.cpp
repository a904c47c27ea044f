// The built-in scenes' names and text (embedded from scenes/*.yaml at build time), and the data
// folder their mesh files come from.

#include <cstdlib>

#include "builtin_scenes.hpp"
#include "cariesim/scene/scene.hpp"

namespace cariesim {

std::vector<std::string> builtin_scene_names() {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < scene_detail::kBuiltinSceneCount; ++i) {
    names.emplace_back(scene_detail::kBuiltinScenes[i].name);
  }
  return names;
}

std::string_view builtin_scene_yaml(std::string_view name) {
  for (std::size_t i = 0; i < scene_detail::kBuiltinSceneCount; ++i) {
    if (scene_detail::kBuiltinScenes[i].name == name) return scene_detail::kBuiltinScenes[i].yaml;
  }
  return {};
}

std::filesystem::path data_directory() {
  // The environment first (an installed or relocated program), then the build's data folder.
  if (const char* env = std::getenv("CARIESIM_DATA_DIR"); env != nullptr && *env != '\0') {
    return std::filesystem::path(env);
  }
  return std::filesystem::path(CARIESIM_DATA_DIR);
}

}  // namespace cariesim
