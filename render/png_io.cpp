#include "png_io.h"

#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "base/errors.h"

namespace cvt::render {

void write_png(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgba, bool keep_alpha) {
  if (rgba.size() != std::size_t(width) * height * 4)
    throw InputError("cannot write " + path + ": pixel buffer has the wrong size");
  const int channels = keep_alpha ? 4 : 3;
  std::vector<std::uint8_t> pixels;
  const std::uint8_t* data = rgba.data();
  if (!keep_alpha) {
    pixels.resize(std::size_t(width) * height * 3);
    for (std::size_t i = 0, n = std::size_t(width) * height; i < n; ++i)
      for (int c = 0; c < 3; ++c) pixels[3 * i + c] = rgba[4 * i + c];
    data = pixels.data();
  }
  // The temp name keeps the .png extension: OpenImageIO picks the format from it.
  const std::filesystem::path target(path);
  const std::filesystem::path temp =
      target.parent_path() / ("." + target.stem().string() + ".tmp.png");
  auto out = OIIO::ImageOutput::create(temp.string());
  if (!out) throw InputError("cannot write " + path + ": " + OIIO::geterror());
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
  if (!out->open(temp.string(), spec) || !out->write_image(OIIO::TypeDesc::UINT8, data) ||
      !out->close()) {
    const std::string error = out->geterror();
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
