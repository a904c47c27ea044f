#include "trainee.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <fmt/format.h>

#include <algorithm>
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

InstructorLock::InstructorLock(std::string hash, std::function<Clock::time_point()> now)
    : hash_(std::move(hash)), now_(std::move(now)) {}

InstructorLock::~InstructorLock() {
  if (pending_.valid()) pending_.wait();
}

InstructorLock::InstructorLock(InstructorLock&&) noexcept = default;

InstructorLock& InstructorLock::operator=(InstructorLock&& other) noexcept {
  // A check in flight on this lock ends before it is replaced.
  if (this != &other) {
    if (pending_.valid()) pending_.wait();
    hash_ = std::move(other.hash_);
    now_ = std::move(other.now_);
    pending_ = std::move(other.pending_);
    unlocked_ = other.unlocked_;
    refused_ = other.refused_;
    failures_ = other.failures_;
    deferred_ = other.deferred_;
    next_try_ = other.next_try_;
  }
  return *this;
}

double InstructorLock::backoff_seconds(int failures) {
  if (failures < kFreeTries) return 0.0;
  const int doublings = std::min(failures - kFreeTries, 30);
  return std::min(std::ldexp(1.0, doublings), kMaxBackoff);
}

double InstructorLock::wait_seconds() const {
  const double left = std::chrono::duration<double>(next_try_ - now_()).count();
  return std::max(left, 0.0);
}

InstructorLock::Submitted InstructorLock::submit(std::string passphrase) {
  // Nothing unlocks without a hash; one check at a time; none within the back-off.
  if (hash_.empty()) {
    ++refused_;
    return Submitted::NoHash;
  }
  if (pending_.valid()) return Submitted::Busy;
  if (wait_seconds() > 0.0) {
    ++deferred_;
    return Submitted::Wait;
  }
  // PBKDF2 on the worker (the hash was checked when the course file was read; a throw is a refusal).
  pending_ = std::async(std::launch::async, [hash = hash_, passphrase = std::move(passphrase)] {
    try {
      return training::verify_passphrase(passphrase, hash);
    } catch (const Error&) {
      return false;
    }
  });
  return Submitted::Checking;
}

std::optional<bool> InstructorLock::poll() {
  if (!pending_.valid() || pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    return std::nullopt;
  // The outcome: open, or one more wrong passphrase and the wait before the next try.
  const bool right = pending_.get();
  if (right) {
    unlocked_ = true;
    failures_ = 0;
    next_try_ = {};
    return true;
  }
  ++refused_;
  ++failures_;
  next_try_ = now_() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(backoff_seconds(failures_)));
  return false;
}

std::optional<bool> InstructorLock::wait() {
  if (pending_.valid()) pending_.wait();
  return poll();
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
    // A key's or lock's line may end in a comment; a passphrase is the rest of its line, as typed.
    if (action != "passphrase") {
      const std::size_t hash = step.argument.find('#');
      if (hash != std::string::npos) step.argument.erase(hash);
      const std::size_t last = step.argument.find_last_not_of(" \t");
      step.argument.erase(last == std::string::npos ? 0 : last + 1);
    }
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
