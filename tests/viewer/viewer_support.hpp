#pragma once
// What the viewer's Xvfb tests share: running `cariesim` under xvfb-run, the artefacts folder, the
// PNG screenshots, and queries of the status files.
#include <stb/stb_image.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace cariesim::test {

/// build/test-artifacts/viewer (created).
std::filesystem::path viewer_artefacts();

/// True when xvfb-run is installed.
bool have_xvfb();

struct RunResult {
  int status = -1;
  std::string out, err;
};

/// `cariesim ARGS` under xvfb-run with the shared test tree cache (ARGS split as support/command.hpp
/// says, no shell), in `working_dir` (empty: the test's folder), its output also in
/// viewer_artefacts()/NAME.out and NAME.log; generous time limit. `screen`: the virtual screen's
/// size, "WIDTHxHEIGHT" (px).
RunResult run_under_xvfb(const std::string& args, const std::string& name,
                         const std::filesystem::path& working_dir = {},
                         const std::string& screen = "1280x800");

/// The xvfb-run command line that starts `cariesim` (the words of the arguments follow it) on a
/// virtual screen of `screen` ("WIDTHxHEIGHT", px).
std::vector<std::string> xvfb_cariesim(const std::string& screen = "1280x800");

/// An RGB image read from a PNG (data null when unreadable).
struct Image {
  int w = 0, h = 0;
  std::unique_ptr<unsigned char, void (*)(void*)> data{nullptr, stbi_image_free};
  [[nodiscard]] const unsigned char* at(int x, int y) const {
    return data.get() + 3 * (static_cast<std::size_t>(y) * w + x);
  }
};
Image load_png(const std::filesystem::path& file);

/// Python's value of EXPRESSION on the JSON file as `d` (e.g. `d["instructor"]["refused"]`), printed
/// by print(); "<error: ...>" when the expression fails.
std::string json_query(const std::filesystem::path& json, const std::string& expression);

}  // namespace cariesim::test
