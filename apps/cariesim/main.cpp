// cariesim: one binary, subcommands (DESIGN.md §6). Each subcommand lives in its own file and
// registers itself through commands.hpp.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "commands.hpp"
#include "cariesim/common/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"cariesim: 6-DoF haptic simulator for probing dental caries"};
  app.require_subcommand(0, 1);
  cariesim::cli::Registry registry;
  cariesim::cli::register_all(app, registry);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return registry.run(app);
  } catch (const cariesim::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  }
}
