// The wall-clock time stamp of records (common/clock.hpp).
#include "cariesim/common/clock.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>

namespace cariesim {

std::string utc_now_iso8601() {
  // Whole seconds through gmtime_r, milliseconds from the same reading.
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &utc);
  char text[40];
  std::snprintf(text, sizeof text, "%s.%03dZ", date, static_cast<int>(ms));
  return text;
}

}  // namespace cariesim
