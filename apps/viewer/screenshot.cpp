#include "screenshot.hpp"

#include <epoxy/gl.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <string>

#include "cariesim/common/error.hpp"

namespace cariesim::viewer {

Image read_framebuffer(int width, int height) {
  // GL rows start at the bottom; PNG rows at the top.
  Image image;
  image.width = std::max(width, 0);
  image.height = std::max(height, 0);
  const std::size_t row = static_cast<std::size_t>(image.width) * 3;
  std::vector<uint8_t> raw(row * static_cast<std::size_t>(image.height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, image.width, image.height, GL_RGB, GL_UNSIGNED_BYTE, raw.data());
  image.rgb.resize(raw.size());
  for (int y = 0; y < image.height; ++y)
    std::copy_n(raw.data() + row * static_cast<std::size_t>(image.height - 1 - y), row,
                image.rgb.data() + row * static_cast<std::size_t>(y));
  return image;
}

void write_png(const Image& image, const std::filesystem::path& file) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    throw Error(file.string() + ": no image to write");
  std::error_code ec;
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), ec);
  if (stbi_write_png(file.c_str(), image.width, image.height, 3, image.rgb.data(), image.width * 3) == 0)
    throw Error(file.string() + ": cannot write the PNG");
}

}  // namespace cariesim::viewer
