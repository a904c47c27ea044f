#pragma once
// Parameter overrides applied to a scene's YAML document before it is read (scene/scene.hpp's
// parse_scene; docs/scene-format.md, "Overrides"). Private to the scene module.

#include <yaml-cpp/yaml.h>

#include <span>

#include "cariesim/io/yaml.hpp"
#include "cariesim/scene/scene_desc.hpp"

namespace cariesim::scene_detail {

// Replaces, in order, the node at each override's key in `root` (a scene document) by its value
// parsed as YAML (one bounded document, io::parse_document). Missing mappings on the way are
// created (an unknown key is then refused by the reader, as in a file); a sequence index must
// exist. Each placed node is registered with `reader` (io::Reader::locate_as) so that a failure
// inside it names "FILE (override KEY)". Throws cariesim::Error naming the override for a path that
// does not fit the document (an index past the end, a step into a scalar).
void apply_overrides(YAML::Node& root, std::span<const SceneOverride> overrides, io::Reader& reader);

}  // namespace cariesim::scene_detail
