#include "viewer_support.hpp"

#include <fstream>

#include "support/command.hpp"
#include "support/files.hpp"

namespace cariesim::test {

namespace fs = std::filesystem;

fs::path viewer_artefacts() {
  const fs::path dir = fs::path(CARIESIM_BINARY_DIR) / "test-artifacts" / "viewer";
  fs::create_directories(dir);
  return dir;
}

bool have_xvfb() { return on_path("xvfb-run"); }

std::vector<std::string> xvfb_cariesim(const std::string& screen) {
  return {"timeout", "900", "xvfb-run", "-a", "-s", "-screen 0 " + screen + "x24", CARIESIM_EXE};
}

RunResult run_under_xvfb(const std::string& args, const std::string& name, const fs::path& working_dir,
                         const std::string& screen) {
  std::vector<std::string> argv = xvfb_cariesim(screen);
  for (std::string& w : words(args)) argv.push_back(std::move(w));
  io::ProcessOptions options;
  options.environment = {"CARIESIM_CACHE_DIR=" + (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string()};
  options.working_dir = working_dir.string();
  const CommandOutput c = run_command(argv, options);
  const fs::path dir = viewer_artefacts();
  std::ofstream(dir / (name + ".out"), std::ios::binary) << c.out;
  std::ofstream(dir / (name + ".log"), std::ios::binary) << c.err;
  RunResult r;
  r.status = c.status;
  r.out = c.out;
  r.err = c.err;
  return r;
}

Image load_png(const fs::path& file) {
  Image img;
  int channels = 0;
  img.data.reset(stbi_load(file.c_str(), &img.w, &img.h, &channels, 3));
  return img;
}

std::string json_query(const fs::path& json, const std::string& expression) {
  const fs::path script = json.string() + ".query.py", result = json.string() + ".query.txt";
  std::ofstream(script) << "import json, sys\nd = json.load(open(sys.argv[1]))\ntry:\n    print("
                        << expression << ")\nexcept Exception as e:\n    print('<error: %r>' % e)\n";
  const CommandOutput c = run_command({"python3", script.string(), json.string()});
  std::ofstream(result, std::ios::binary) << c.out << c.err;
  std::string text = c.out + c.err;
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  return text;
}

}  // namespace cariesim::test
