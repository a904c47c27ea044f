#include "trainee.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <sstream>

#include "cariesim/common/error.hpp"
#include "cariesim/io/file.hpp"
#include "cariesim/training/course.hpp"

namespace cariesim::viewer {

ViewSettings trainee_settings(const ViewSettings& settings) {
  ViewSettings s = settings;
  s.show_lesions = false;
  s.haptic_ghost = false;
  s.recorded_ghost = false;
  s.contacts = false;
  s.tunnel = false;
  s.force_arrow = false;
  s.tip_xray = false;
  s.trees = false;
  return s;
}

bool InstructorLock::try_unlock(std::string_view passphrase) {
  // Nothing unlocks without a hash; the hash was checked when the course file was read.
  if (hash_.empty() || !training::verify_passphrase(passphrase, hash_)) {
    ++refused_;
    return false;
  }
  unlocked_ = true;
  return true;
}

int script_key_code(std::string_view name) {
  // A single letter or digit, or a named key.
  if (name.size() == 1) {
    const char c = name[0];
    if (c >= 'a' && c <= 'z') return GLFW_KEY_A + (c - 'a');
    if (c >= 'A' && c <= 'Z') return GLFW_KEY_A + (c - 'A');
    if (c >= '0' && c <= '9') return GLFW_KEY_0 + (c - '0');
  }
  if (name == "Enter") return GLFW_KEY_ENTER;
  if (name == "Space") return GLFW_KEY_SPACE;
  if (name == "Escape") return GLFW_KEY_ESCAPE;
  return -1;
}

std::vector<ScriptStep> parse_script(std::string_view text, const std::string& file) {
  std::vector<ScriptStep> steps;
  std::istringstream lines{std::string(text)};
  std::string line;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto fail = [&](const std::string& message) {
      throw Error(fmt::format("{}:{}: {}", file, number, message));
    };
    // SECONDS ACTION [ARGUMENT...]
    std::istringstream in(line);
    std::string time_text, action;
    in >> time_text >> action;
    ScriptStep step;
    step.line = number;
    const auto [end, ec] = std::from_chars(time_text.data(), time_text.data() + time_text.size(), step.t);
    if (ec != std::errc() || end != time_text.data() + time_text.size() || !std::isfinite(step.t) ||
        step.t < 0)
      fail(fmt::format("'{}' is not a time in seconds (>= 0)", time_text));
    if (!steps.empty() && step.t < steps.back().t)
      fail(fmt::format("time {:g} s is before the previous step's {:g} s", step.t, steps.back().t));
    std::getline(in >> std::ws, step.argument);
    step.action = action;
    if (action == "key") {
      if (script_key_code(step.argument) < 0)
        fail(fmt::format("unknown key '{}' (a letter, a digit, Enter, Space or Escape)", step.argument));
    } else if (action == "passphrase") {
      // The rest of the line, as typed.
    } else if (action == "lock") {
      if (!step.argument.empty()) fail("lock takes no argument");
    } else {
      fail(fmt::format("unknown action '{}' (key, passphrase, lock)", action));
    }
    steps.push_back(std::move(step));
  }
  return steps;
}

std::vector<ScriptStep> load_script(const std::string& file) {
  return parse_script(io::read_file(file, "trainee script"), file);
}

}  // namespace cariesim::viewer
