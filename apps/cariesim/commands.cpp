#include "commands.hpp"

#include <cstdio>

namespace cariesim::cli {

// Every subcommand registers itself here, in the order `cariesim --help` lists them.
void register_all(CLI::App& app, Registry& registry) {
  auto* version = app.add_subcommand("version", "Print the version");
  registry.add(version, [] {
    std::printf("cariesim %s\n", CARIESIM_VERSION);
    return 0;
  });
}

}  // namespace cariesim::cli
