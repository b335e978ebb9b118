#include "png_io.h"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "base/errors.h"

namespace cvt::render {

void write_png(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgba, bool keep_alpha) {
  if (rgba.size() != std::size_t(width) * height * 4)
    throw InputError("cannot write " + path + ": pixel buffer has the wrong size");
  const int channels = keep_alpha ? 4 : 3;
  std::vector<std::uint8_t> pixels(std::size_t(width) * height * channels);
  for (std::size_t i = 0, n = std::size_t(width) * height; i < n; ++i) {
    const std::uint8_t* p = &rgba[4 * i];
    std::uint8_t* q = &pixels[channels * i];
    for (int c = 0; c < 3; ++c) q[c] = p[c];
    if (!keep_alpha) continue;
    // PNG stores unassociated alpha: the colours are divided by alpha, as OpenImageIO's
    // writer did with the same framebuffer (so screenshots keep their pixels).
    q[3] = p[3];
    if (p[3] != 0)
      for (int c = 0; c < 3; ++c) q[c] = std::uint8_t(std::min(255u, p[c] * 255u / p[3]));
  }
  // Written beside the target and renamed, so a failed write never leaves half a file.
  const std::filesystem::path target(path);
  const std::filesystem::path temp =
      target.parent_path() / ("." + target.stem().string() + ".tmp.png");
  std::FILE* file = std::fopen(temp.string().c_str(), "wb");
  if (!file) {
    throw InputError("cannot write " + path + ": cannot create " + temp.string() + " (" +
                     std::strerror(errno) + ")");
  }
  // libpng's simplified API: errors come back in image.message, no longjmp here.
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = png_uint_32(width);
  image.height = png_uint_32(height);
  image.format = keep_alpha ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB;
  const bool written = png_image_write_to_stdio(&image, file, 0, pixels.data(), 0, nullptr) != 0;
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) {
    const std::string error = !written ? std::string(image.message) : std::strerror(errno);
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw InputError("cannot write " + path + ": " + error);
  }
  std::error_code ec;
  std::filesystem::rename(temp, target, ec);
  if (ec) {
    std::filesystem::remove(temp, ec);
    throw InputError("cannot write " + path + ": " + ec.message());
  }
}

}  // namespace cvt::render
