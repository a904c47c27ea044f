#pragma once
// The built-in studies: studies/NAME.yaml embedded at build time (cmake/embed_text.cmake).
#include <cstddef>
#include <string_view>

namespace cariesim::training {

struct BuiltinStudy {
  std::string_view name;  ///< the file's stem
  std::string_view yaml;  ///< its text
};

extern const BuiltinStudy kBuiltinStudies[];
extern const std::size_t kBuiltinStudyCount;

}  // namespace cariesim::training
