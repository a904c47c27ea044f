#include "commands.hpp"

#include <cstdio>

namespace cariesim::cli {

// Defined in the command files (tree_command.cpp, scene_command.cpp, export_command.cpp).
void register_tree(CLI::App& app, Registry& registry);
void register_export(CLI::App& app, Registry& registry);
void register_scene(CLI::App& app, Registry& registry);
int default_tree_report();

// Every subcommand registers itself here, in the order `cariesim --help` lists them.
void register_all(CLI::App& app, Registry& registry) {
  auto* version = app.add_subcommand("version", "Print the version");
  registry.add(version, [] {
    std::printf("cariesim %s\n", CARIESIM_VERSION);
    return 0;
  });
  register_sim(app, registry);
  register_experiment(app, registry);
  register_tree(app, registry);
  register_scene(app, registry);
  register_export(app, registry);
  // No subcommand: until the viewer exists, build the default scene and print its tree report.
  registry.set_default(default_tree_report);
}

}  // namespace cariesim::cli
