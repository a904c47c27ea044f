// cariesim_standin_haply_service: the Inverse Service stand-in as a program (test code, built in the
// build tree only), so `cariesim run --device haply:URL` can be tried by hand without a device:
//   build/tests/cariesim_standin_haply_service [--http-port P] [--ws-port Q] [--version V] [--hand X,Y,Z]
// prints the `haply:` URL and serves until SIGINT or SIGTERM. --hand is the simulated hand's
// constant force on the cursor (N, device frame: x right, y forward, z up).
#include <signal.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>

#include "standins/haply/inverse_service.hpp"

namespace {

// "X,Y,Z" as three numbers; false when it is not.
bool parse_vec(const std::string& text, cariesim::Vec3& out) {
  std::istringstream in(text);
  char c1 = 0, c2 = 0;
  return static_cast<bool>(in >> out.x() >> c1 >> out.y() >> c2 >> out.z()) && c1 == ',' && c2 == ',' &&
         in.peek() == std::char_traits<char>::eof();
}

// A port in [1, 65535]; 0 when it is not.
unsigned short parse_port(const std::string& text) {
  char* end = nullptr;
  const long port = std::strtol(text.c_str(), &end, 10);
  return end != text.c_str() && *end == '\0' && port >= 1 && port <= 65535 ? static_cast<unsigned short>(port)
                                                                           : 0;
}

}  // namespace

int main(int argc, char** argv) {
  // The options, each with one value.
  cariesim::test::InverseServiceOptions options;
  cariesim::Vec3 hand = cariesim::Vec3::Zero();
  for (int i = 1; i < argc; ++i) {
    const std::string option = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "cariesim_standin_haply_service: " << option << " needs a value\n";
      return 2;
    }
    const std::string value = argv[++i];
    bool ok = true;
    if (option == "--http-port")
      ok = (options.http_port = parse_port(value)) != 0;
    else if (option == "--ws-port")
      ok = (options.ws_port = parse_port(value)) != 0;
    else if (option == "--version")
      options.version = value;
    else if (option == "--hand")
      ok = parse_vec(value, hand);
    else
      ok = false;
    if (!ok) {
      std::cerr << "cariesim_standin_haply_service: bad option " << option << " " << value
                << " (expected --http-port P, --ws-port Q, --version V, --hand X,Y,Z)\n";
      return 2;
    }
  }

  // Serve until SIGINT or SIGTERM (waited for synchronously, so no handler runs on another thread).
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  try {
    cariesim::test::InverseService service(options);
    service.push_hand(hand);
    std::cout << "haply:" << service.url() << std::endl;
    int signal = 0;
    sigwait(&stop, &signal);
    std::cout << service.commands() << " commands" << std::endl;
  } catch (const std::exception& e) {
    std::cerr << "cariesim_standin_haply_service: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
