#pragma once
// File helpers shared by the tests.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace cariesim::test {

/// The whole content of a file ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The command lines starting with `prefix` in the first ```sh block after the first occurrence of
/// `heading` (a Markdown section heading) in `doc`, without their trailing `# comments`; empty when
/// the section or its block is missing. For tests that run a page's examples as written.
inline std::vector<std::string> doc_commands(const std::string& doc, const std::string& heading,
                                             const std::string& prefix) {
  std::vector<std::string> commands;
  const std::size_t section = doc.find(heading);
  if (section == std::string::npos) return commands;
  const std::size_t open = doc.find("```sh\n", section);
  if (open == std::string::npos) return commands;
  const std::size_t close = doc.find("```", open + 6);
  std::istringstream block(doc.substr(open + 6, close - open - 6));
  std::string line;
  while (std::getline(block, line)) {
    if (const std::size_t hash = line.find(" #"); hash != std::string::npos) line.erase(hash);
    while (!line.empty() && line.back() == ' ') line.pop_back();
    if (line.rfind(prefix, 0) == 0) commands.push_back(line);
  }
  return commands;
}

}  // namespace cariesim::test
