#include "viewer_support.hpp"

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>

#include "support/files.hpp"

namespace cariesim::test {

namespace fs = std::filesystem;

fs::path viewer_artefacts() {
  const fs::path dir = fs::path(CARIESIM_BINARY_DIR) / "test-artifacts" / "viewer";
  fs::create_directories(dir);
  return dir;
}

int shell(const std::string& command) {
  const int raw = std::system(command.c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

bool have_xvfb() { return shell("command -v xvfb-run >/dev/null 2>&1") == 0; }

RunResult run_under_xvfb(const std::string& args, const std::string& name) {
  const fs::path dir = viewer_artefacts();
  const fs::path out = dir / (name + ".out"), err = dir / (name + ".log");
  const std::string command = "CARIESIM_CACHE_DIR='" +
                              (fs::path(CARIESIM_BINARY_DIR) / "test-cache").string() +
                              "' timeout 900 xvfb-run -a -s '-screen 0 1280x800x24' '" + CARIESIM_EXE + "' " +
                              args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  RunResult r;
  r.status = shell(command);
  r.out = read_text(out);
  r.err = read_text(err);
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
  shell("python3 '" + script.string() + "' '" + json.string() + "' >'" + result.string() + "' 2>&1");
  std::string text = read_text(result);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  return text;
}

}  // namespace cariesim::test
