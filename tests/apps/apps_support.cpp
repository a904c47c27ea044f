#include "apps/apps_support.hpp"

#include <sys/wait.h>

#include <cstdlib>

#include "support/files.hpp"

namespace cariesim::test {

CommandResult run_cariesim(const std::string& args, const std::filesystem::path& scratch,
                           const std::string& env) {
  const std::filesystem::path out = scratch / "stdout.txt";
  const std::filesystem::path err = scratch / "stderr.txt";
  const std::string command = env + (env.empty() ? "" : " ") + "'" + std::string(CARIESIM_EXE) + "' " + args +
                              " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int raw = std::system(command.c_str());
  CommandResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

}  // namespace cariesim::test
