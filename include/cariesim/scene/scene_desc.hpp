#pragma once
/// The parsed form of a scene file (see docs/scene-format.md). Owned by the scene module.
/// Placeholder until the scene module defines it in full.

#include <string>

namespace cariesim {

struct SceneDesc {
  std::string name;
};

}  // namespace cariesim
