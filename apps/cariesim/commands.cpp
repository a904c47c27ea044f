#include "commands.hpp"

#include <fmt/format.h>

#include <cstdio>

#include "cariesim/common/error.hpp"
#include "cariesim/scene/scene.hpp"
#include "cariesim/training/study.hpp"

namespace cariesim::cli {

CLI::Option* add_seed_option(CLI::App* sub, std::optional<uint64_t>& seed, const std::string& description) {
  // The text is checked before CLI11 converts it (its conversion of "-1" to an unsigned type wraps).
  const CLI::Validator strict(
      [](std::string& text) -> std::string {
        if (training::parse_seed(text)) return {};
        return fmt::format("'{}' is not a seed: an integer in [0, {}] in decimal digits", text,
                           training::kMaxSeed);
      },
      fmt::format("SEED in [0 - {}]", training::kMaxSeed));
  return sub->add_option("--seed", seed, description)->check(strict);
}

void add_set_option(CLI::App* sub, std::vector<std::string>& sets) {
  // Each argument is read as it is given, so a malformed key is named before anything runs.
  const CLI::Validator key_path(
      [](std::string& text) -> std::string {
        try {
          (void)parse_override(text);
        } catch (const Error& e) {
          return e.what();
        }
        return {};
      },
      "KEY=VALUE");
  sub->add_option("--set", sets,
                  "Override a scene parameter, e.g. --set lesions[0].material.k_c=0.4 (repeatable; "
                  "checked as in the scene file)")
      ->allow_extra_args(false)
      ->check(key_path);
}

std::vector<SceneOverride> scene_overrides(const std::vector<std::string>& sets) {
  std::vector<SceneOverride> overrides;
  for (const std::string& set : sets) overrides.push_back(parse_override(set));
  return overrides;
}

// Defined in the command files (run_command.cpp, tree_command.cpp, scene_command.cpp,
// export_command.cpp, servo_command.cpp).
void register_run(CLI::App& app, Registry& registry);
void register_tree(CLI::App& app, Registry& registry);
void register_servo(CLI::App& app, Registry& registry);
void register_export(CLI::App& app, Registry& registry);
void register_scene(CLI::App& app, Registry& registry);
void register_study(CLI::App& app, Registry& registry);   // study_command.cpp
void register_course(CLI::App& app, Registry& registry);  // course_command.cpp
void register_report(CLI::App& app, Registry& registry);  // report_command.cpp
void register_device(CLI::App& app, Registry& registry);  // device_command.cpp
void register_review(CLI::App& app, Registry& registry);  // run_command.cpp

// Every subcommand registers itself here, in the order `cariesim --help` lists them.
void register_all(CLI::App& app, Registry& registry) {
  auto* version = app.add_subcommand("version", "Print the version");
  registry.add(version, [] {
    std::printf("cariesim %s\n", CARIESIM_VERSION);
    return 0;
  });
  // `run` is also the default without a subcommand: the simulator window on real-arch.
  register_run(app, registry);
  register_sim(app, registry);
  register_experiment(app, registry);
  register_servo(app, registry);
  register_device(app, registry);
  register_tree(app, registry);
  register_scene(app, registry);
  register_export(app, registry);
  register_study(app, registry);
  register_course(app, registry);
  register_report(app, registry);
  register_review(app, registry);
}

}  // namespace cariesim::cli
