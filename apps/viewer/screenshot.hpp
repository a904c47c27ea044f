#pragma once
/// Screenshots for automation (`--screenshot FILE.png --exit-after SECONDS`): the framebuffer read
/// back with glReadPixels and written as PNG (stb_image_write, from Debian's libstb).

#include <cstdint>
#include <filesystem>
#include <vector>

namespace cariesim::viewer {

/// An RGB image, rows from the top.
struct Image {
  int width = 0;             ///< px
  int height = 0;            ///< px
  std::vector<uint8_t> rgb;  ///< width * height * 3 bytes
};

/// Reads the current GL read buffer (the back buffer after drawing) into an image (top row first).
Image read_framebuffer(int width, int height);

/// Writes an image as PNG; throws cariesim::Error naming the file when it cannot.
void write_png(const Image& image, const std::filesystem::path& file);

}  // namespace cariesim::viewer
