#include "apps/apps_support.hpp"

#include <sstream>

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

// A closed cube of side `s` mm as ASCII STL (12 outward triangles).
std::string cube_stl(double s) {
  const double v[8][3] = {{0, 0, 0}, {s, 0, 0}, {s, s, 0}, {0, s, 0},
                          {0, 0, s}, {s, 0, s}, {s, s, s}, {0, s, s}};
  const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                        {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  std::ostringstream out;
  out << "solid cube\n";
  for (const auto& t : f) {
    out << " facet normal 0 0 0\n  outer loop\n";
    for (int k : t) out << "   vertex " << v[k][0] << ' ' << v[k][1] << ' ' << v[k][2] << '\n';
    out << "  endloop\n endfacet\n";
  }
  out << "endsolid cube\n";
  return out.str();
}

}  // namespace cariesim::test
