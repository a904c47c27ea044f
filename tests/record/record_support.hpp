#pragma once
// Helpers of the record tests: a synthetic servo stream whose every field varies with the sample
// index (so a round trip can compare field by field), a session row, and a scratch folder.
#include <cstddef>
#include <filesystem>
#include <string>

#include "cariesim/record/recorder.hpp"

namespace cariesim::test {

/// Sample `i` of a synthetic stream at `rate_hz`: t = i / rate_hz, poses on a slow helix with a
/// turning orientation, a wrench, the four states in turn, depths, flags and buttons; deterministic.
ServoSample synthetic_sample(std::size_t i, double rate_hz);

/// A session row with text that needs CSV quoting (commas, quotes) and a full 64-bit hash.
SessionInfo synthetic_session(double rate_hz);

/// Exact equality for doubles, NaN equal to NaN (SQLite stores NaN as NULL, read back as NaN).
bool same(double a, double b);

/// A fresh folder under the temp directory, removed by the destructor.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name);
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace cariesim::test
