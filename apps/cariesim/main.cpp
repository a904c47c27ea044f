// cariesim: one binary, subcommands (docs/cli.md). Each subcommand lives in its own file and
// registers itself through commands.hpp.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <exception>
#include <memory>

#include "cariesim/common/error.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  // Every log line goes to stderr, so stdout carries only a command's output (`tree --json`, `servo`'s
  // report): spdlog's default logger, set once here before anything logs.
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("", std::make_shared<spdlog::sinks::stderr_color_sink_mt>()));
  // A file that reaches the size limit (ulimit -f, a quota) fails its write with EFBIG, which the
  // writer reports (a recording's error, exit status 4), instead of SIGXFSZ ending the program with
  // nothing said and the record left open.
  std::signal(SIGXFSZ, SIG_IGN);
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
