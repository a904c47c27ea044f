// cariesim: one binary, subcommands (docs/cli.md). Each subcommand lives in its own file and
// registers itself through commands.hpp.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <exception>
#include <memory>

#include "cariesim/common/error.hpp"
#include "cariesim/device/safety.hpp"
#include "commands.hpp"

namespace {

// A fatal signal (a crash on any thread, the viewer's included) or one that ends the program (Ctrl-C,
// kill, a closed terminal) where the command has no handler of its own (`servo` and `device check`
// shut down cleanly on their own): every force stops in the next servo cycle (ForceSafety), the servo
// thread is given a few cycles to write the zero wrench, then the signal takes its default course
// (the exit status, the core dump), as it did before the handler.
extern "C" void on_fatal_signal(int signal) {
  cariesim::request_force_stop();
  const timespec pause{0, 5'000'000};  // 5 ms: five cycles at 1 kHz
  nanosleep(&pause, nullptr);
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

}  // namespace

int main(int argc, char** argv) {
  // Every log line goes to stderr, so stdout carries only a command's output (`tree --json`, `servo`'s
  // report): spdlog's default logger, set once here before anything logs.
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("", std::make_shared<spdlog::sinks::stderr_color_sink_mt>()));
  // A file that reaches the size limit (ulimit -f, a quota) fails its write with EFBIG, which the
  // writer reports (a recording's error, exit status 4), instead of SIGXFSZ ending the program with
  // nothing said and the record left open.
  std::signal(SIGXFSZ, SIG_IGN);
  for (const int fatal : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGINT, SIGTERM, SIGHUP})
    std::signal(fatal, on_fatal_signal);
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
