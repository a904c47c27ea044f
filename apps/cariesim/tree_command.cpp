// `cariesim tree MESH|SCENE`: builds sphere trees and reports leaves, levels, build time and the
// surface deviation (p50/p95/max over dense samples) of every part, as text or as one JSON object.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/model_builder.hpp"
#include "cariesim/scene/scene.hpp"
#include "commands.hpp"

namespace cariesim::cli {
namespace {

struct TreeArgs {
  std::string target = "oral-cavity";  // mesh file, scene file or built-in scene name
  std::string mode;                    // "", "tight" or "octree"
  std::optional<int> depth;
  std::optional<double> tolerance;  // mm
  std::size_t samples = 100000;     // surface samples per part
  bool json = false;
  bool quiet = false;
  bool no_cache = false;
  bool no_deviation = false;  // skip the (slow) deviation measurement
};

// A scene (built-in name, .yaml/.yml file) or a mesh file.
bool is_scene(const std::string& target) {
  if (!builtin_scene_yaml(target).empty()) return true;
  std::string ext = std::filesystem::path(target).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".yaml" || ext == ".yml";
}

// Progress on stderr: a rewritten line on a terminal, one line per stage and quarter otherwise.
ProgressFn stderr_progress() {
  struct Last {
    std::string stage;
    int step = -1;
  };
  auto last = std::make_shared<Last>();
  const bool tty = isatty(fileno(stderr)) != 0;
  return [last, tty](std::string_view stage, double fraction) {
    const int step = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * (tty ? 100.0 : 4.0));
    if (stage == last->stage && step == last->step) return;
    const bool new_stage = stage != last->stage;
    last->stage = std::string(stage);
    last->step = step;
    if (tty) {
      std::fprintf(stderr, "\r\033[K%.*s %3d%%", static_cast<int>(stage.size()), stage.data(), step);
      if (step == 100) std::fputc('\n', stderr);
    } else if (new_stage || step == 4) {
      std::fprintf(stderr, "%.*s %3d%%\n", static_cast<int>(stage.size()), stage.data(), step * 25);
    }
    std::fflush(stderr);
  };
}

// JSON string literal (the project's libraries have no JSON writer; names and paths need escaping).
std::string json_string(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out += fmt::format("\\u{:04x}", static_cast<int>(c));
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

// A finite JSON number (JSON has no infinity or NaN).
std::string json_number(double value) { return std::isfinite(value) ? fmt::format("{:.9g}", value) : "null"; }

// One part as a JSON object.
std::string part_json(const PartReport& part, const Model& model) {
  std::string levels;
  for (const std::size_t n : part.nodes_per_level) levels += (levels.empty() ? "" : ", ") + std::to_string(n);
  const CollisionObject& object = model.objects[static_cast<std::size_t>(part.object)];
  std::string out = fmt::format(
      "{{\"name\": {}, \"mode\": \"{}\", \"leaves\": {}, \"levels\": {}, \"nodes_per_level\": [{}], "
      "\"build_seconds\": {}, \"cache_hit\": {}, \"lesion\": {}",
      json_string(part.name), object.tree.mode == TreeMode::Tight ? "tight" : "octree", part.leaves,
      part.levels, levels, json_number(part.build_seconds), part.cache_hit ? "true" : "false", object.lesion);
  if (part.deviation) {
    const Deviation& d = *part.deviation;
    out += fmt::format(
        ", \"deviation_mm\": {{\"p50\": {}, \"p95\": {}, \"max\": {}, \"max_poke_out\": {}, "
        "\"max_fall_short\": {}, "
        "\"samples\": {}}}",
        json_number(d.p50), json_number(d.p95), json_number(d.max), json_number(d.max_poke_out),
        json_number(d.max_fall_short), d.samples);
  }
  if (part.seam_deviation) {
    const Deviation& d = *part.seam_deviation;
    out += fmt::format(
        ", \"seam_deviation_mm\": {{\"band_mm\": {}, \"p50\": {}, \"p95\": {}, \"max\": {}, "
        "\"max_poke_out\": {}, \"max_fall_short\": {}, \"samples\": {}}}",
        json_number(kSeamBandHalfWidth), json_number(d.p50), json_number(d.p95), json_number(d.max),
        json_number(d.max_poke_out), json_number(d.max_fall_short), d.samples);
  }
  return out + "}";
}

// One part as text lines.
void print_part(const PartReport& part, const Model& model) {
  const CollisionObject& object = model.objects[static_cast<std::size_t>(part.object)];
  std::printf("%-24s %-6s leaves %7zu  levels %2d  build %7.3f s%s\n", part.name.c_str(),
              object.tree.mode == TreeMode::Tight ? "tight" : "octree", part.leaves, part.levels,
              part.build_seconds, part.cache_hit ? " (cache hit)" : "");
  std::string levels;
  for (const std::size_t n : part.nodes_per_level) levels += fmt::format(" {}", n);
  std::printf("  nodes per level:%s\n", levels.c_str());
  if (part.deviation) {
    const Deviation& d = *part.deviation;
    std::printf(
        "  deviation mm: p50 %.4f  p95 %.4f  max %.4f  (poke-out %.4f, fall-short %.4f, %zu samples)\n",
        d.p50, d.p95, d.max, d.max_poke_out, d.max_fall_short, d.samples);
  }
  if (part.seam_deviation) {
    const Deviation& d = *part.seam_deviation;
    std::printf(
        "  seam deviation mm (all parts, +/-%.1f mm around the border): p50 %.4f  p95 %.4f  max %.4f  "
        "(poke-out %.4f, fall-short %.4f, %zu samples)\n",
        kSeamBandHalfWidth, d.p50, d.p95, d.max, d.max_poke_out, d.max_fall_short, d.samples);
  }
}

int run_tree(const TreeArgs& args) {
  // The scene: a built-in, a YAML file, or a one-object scene around a mesh file.
  const bool scene_target = is_scene(args.target);
  const SceneDesc scene = scene_target ? load_scene(args.target) : mesh_scene(args.target);

  BuildOptions options;
  options.use_cache = !args.no_cache;
  if (!args.mode.empty()) options.mode = args.mode == "octree" ? TreeMode::Octree : TreeMode::Tight;
  options.octree_depth = args.depth;
  options.tolerance = args.tolerance;
  options.measure_deviation = !args.no_deviation;
  options.deviation_samples = args.samples;
  if (!args.quiet) options.progress = stderr_progress();

  BuildReport report;
  const Model model = build_model(scene, options, &report);

  // A mesh: its one part. A scene: every part.
  if (args.json) {
    if (!scene_target) {
      std::printf("%s\n", part_json(report.parts.at(0), model).c_str());
      return 0;
    }
    std::string parts;
    for (const PartReport& part : report.parts)
      parts += (parts.empty() ? "\n    " : ",\n    ") + part_json(part, model);
    std::printf("{\"scene\": %s, \"origin\": %s, \"build_seconds\": %s, \"parts\": [%s\n  ]}\n",
                json_string(scene.name).c_str(), json_string(scene.origin).c_str(),
                json_number(report.total_seconds).c_str(), parts.c_str());
    return 0;
  }
  std::printf("%s: %zu parts, %zu materials, %zu lesions, built in %.3f s\n", scene.name.c_str(),
              report.parts.size(), model.defaults.materials.size(), model.lesions.size(),
              report.total_seconds);
  for (const PartReport& part : report.parts) print_part(part, model);
  std::printf("tool: %zu spheres\n", model.tool.tree.leaf_count());
  return 0;
}

}  // namespace

void register_tree(CLI::App& app, Registry& registry) {
  auto args = std::make_shared<TreeArgs>();
  auto* tree = app.add_subcommand("tree", "Build sphere trees of a mesh or a scene and report them");
  tree->add_option("target", args->target, "a mesh file (STL/OBJ/PLY), a scene YAML file or a built-in scene")
      ->required();
  tree->add_option("--mode", args->mode, "tree mode of every object")
      ->check(CLI::IsMember({"tight", "octree"}));
  tree->add_option("--depth", args->depth, "octree depth (levels)")->check(CLI::Range(1, 7));
  tree->add_option("--tolerance", args->tolerance, "tight mode: target surface deviation, mm")
      ->check(finite_range(0.001, 10.0));
  tree->add_option("--samples", args->samples, "surface samples for the deviation, per part")
      ->check(CLI::Range(1000, 10000000));
  tree->add_flag("--json", args->json, "print one JSON object");
  tree->add_flag("--quiet", args->quiet, "no progress on stderr");
  tree->add_flag("--no-cache", args->no_cache, "neither read nor write the tree cache");
  tree->add_flag("--no-deviation", args->no_deviation, "do not measure the surface deviation");
  registry.add(tree, [args] { return run_tree(*args); });
}

}  // namespace cariesim::cli
