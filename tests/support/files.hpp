#pragma once
// File helpers shared by the tests.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace cariesim::test {

/// The whole content of a file ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace cariesim::test
