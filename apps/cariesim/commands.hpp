#pragma once
// Subcommand registry of the cariesim binary. Each command file defines one `register_<name>`.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "cariesim/scene/scene_desc.hpp"

namespace cariesim::cli {

/// Adds `--set KEY=VALUE` (repeatable) to a subcommand: a scene parameter override
/// (docs/scene-format.md, "Overrides"), its key checked as given (parse_override).
void add_set_option(CLI::App* sub, std::vector<std::string>& sets);
/// The overrides of the `--set` arguments, in order.
std::vector<SceneOverride> scene_overrides(const std::vector<std::string>& sets);

/// A number option's check: finite and in [min, max]. CLI11's Range and NonNegativeNumber let NaN
/// through (every comparison with NaN is false), so every real-valued option uses this instead.
inline CLI::Validator finite_range(double min, double max) {
  return CLI::Validator(
      [min, max](std::string& text) -> std::string {
        double value = 0.0;
        if (!CLI::detail::lexical_cast(text, value)) return "'" + text + "' is not a number";
        if (!std::isfinite(value)) return "'" + text + "' is not a finite number";
        if (value < min || value > max)
          return "value " + text + " not in range [" + CLI::detail::to_string(min) + " - " +
                 CLI::detail::to_string(max) + "]";
        return {};
      },
      "FINITE in [" + CLI::detail::to_string(min) + " - " + CLI::detail::to_string(max) + "]");
}

/// Adds `--seed` (a study seed) to a subcommand: decimal digits only, in [0, 2^63 - 1]
/// (training::parse_seed, the rule of a study file's `seed:`); anything else (`-1`,
/// `99999999999999999999`, `0x10`) is refused naming the option, never wrapped around.
CLI::Option* add_seed_option(CLI::App* sub, std::optional<uint64_t>& seed, const std::string& description);

/// The --device help of the commands that run the servo loop (`extra`: their own devices first).
std::string device_help(const std::string& extra = "");
/// Adds `--device-profile FILE` (a hardware device's profile, docs/devices.md) to a subcommand.
void add_device_profile_option(CLI::App* sub, std::string& profile);

/// Adds `--spin-us` (ServoOptions::spin_us) to a subcommand that runs the servo loop.
void add_spin_option(CLI::App* sub, double& spin_us);
/// Adds `--no-standby` (ServoOptions::standby off) to a subcommand that runs the servo loop.
void add_standby_option(CLI::App* sub, bool& no_standby);

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
