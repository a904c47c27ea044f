#include "apps/apps_support.hpp"

#include "support/command.hpp"

namespace cariesim::test {

CommandResult run_cariesim(const std::string& args, const std::string& env,
                           const std::filesystem::path& working_dir) {
  io::ProcessOptions options;
  options.environment = words(env);
  options.working_dir = working_dir.string();
  const CommandOutput o = run_command(CARIESIM_EXE, args, options);
  CommandResult r;
  r.status = o.status;
  r.out = o.out;
  r.err = o.err;
  return r;
}

}  // namespace cariesim::test
