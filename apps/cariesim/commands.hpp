#pragma once
// Subcommand registry of the cariesim binary. Each command file defines one `register_<name>`.
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace cariesim::cli {

/// Subcommands and what to run for each; the default (no subcommand) runs `fallback`.
class Registry {
 public:
  void add(CLI::App* sub, std::function<int()> action) { entries_.push_back({sub, std::move(action)}); }
  void set_default(std::function<int()> action) { fallback_ = std::move(action); }
  int run(const CLI::App& app) const {
    for (const auto& e : entries_)
      if (e.sub->parsed()) return e.action();
    (void)app;
    return fallback_ ? fallback_() : 0;
  }

 private:
  struct Entry {
    CLI::App* sub;
    std::function<int()> action;
  };
  std::vector<Entry> entries_;
  std::function<int()> fallback_;
};

void register_all(CLI::App& app, Registry& registry);
void register_sim(CLI::App& app, Registry& registry);
void register_experiment(CLI::App& app, Registry& registry);

}  // namespace cariesim::cli
