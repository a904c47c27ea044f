#pragma once
// The built-in scenes, embedded at build time from scenes/NAME.yaml (cmake/embed_text.cmake writes
// the table into the build tree).

#include <cstddef>
#include <string_view>

namespace cariesim::scene_detail {

struct BuiltinScene {
  std::string_view name;  // e.g. "oral-cavity"
  std::string_view yaml;  // the file's text
};

extern const BuiltinScene kBuiltinScenes[];
extern const std::size_t kBuiltinSceneCount;

}  // namespace cariesim::scene_detail
