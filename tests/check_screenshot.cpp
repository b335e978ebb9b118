// Checks a cvtmesh-gui screenshot: its size, how much of it is not background (the most
// frequent colour), and how many distinct colours it has (a mesh coloured by quality, or
// Voronoi cells, have hundreds; a blank or single-colour picture fails).
// usage: check_screenshot PNG WIDTH HEIGHT MIN_FRACTION MIN_COLOURS
#include <png.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: check_screenshot PNG WIDTH HEIGHT MIN_FRACTION MIN_COLOURS\n");
    return 2;
  }
  const char* path = argv[1];
  const int want_w = std::atoi(argv[2]), want_h = std::atoi(argv[3]);
  const double min_fraction = std::atof(argv[4]);
  const std::size_t min_colours = std::strtoul(argv[5], nullptr, 10);
  // libpng's simplified API, in the file's own channel layout (8 bits per channel).
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path)) {
    std::printf("FAIL: cannot read %s: %s\n", path, image.message);
    return 1;
  }
  image.format &= ~png_uint_32(PNG_FORMAT_FLAG_LINEAR | PNG_FORMAT_FLAG_COLORMAP);
  const int width = int(image.width), height = int(image.height);
  const int channels = int(PNG_IMAGE_SAMPLE_CHANNELS(image.format));
  std::vector<std::uint8_t> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) {
    std::printf("FAIL: cannot decode %s: %s\n", path, image.message);
    return 1;
  }
  // Colours associated with alpha (premultiplied), as OpenImageIO's reader gave them, so the
  // colour counts stay comparable with earlier runs.
  if (channels == 4 || channels == 2)
    for (std::size_t i = 0; i < std::size_t(width) * height; ++i) {
      std::uint8_t* p = &pixels[i * channels];
      const unsigned alpha = p[channels - 1];
      for (int c = 0; c < channels - 1; ++c) p[c] = std::uint8_t(p[c] * alpha / 255);
    }
  std::map<std::uint32_t, std::size_t> histogram;
  for (std::size_t i = 0; i < std::size_t(width) * height; ++i) {
    std::uint32_t key = 0;
    for (int c = 0; c < std::min(channels, 4); ++c) key = key << 8 | pixels[i * channels + c];
    ++histogram[key];
  }
  std::size_t background = 0;
  for (const auto& [colour, count] : histogram) background = std::max(background, count);
  const std::size_t total = std::size_t(width) * height;
  const double fraction = 1.0 - double(background) / double(total);
  std::printf("%s: %dx%d, %d channels, %.1f %% not background, %zu colours\n", path, width, height,
              channels, 100.0 * fraction, histogram.size());
  bool ok = true;
  if (width != want_w || height != want_h) {
    std::printf("FAIL: expected %dx%d\n", want_w, want_h);
    ok = false;
  }
  if (fraction < min_fraction) {
    std::printf("FAIL: expected at least %.1f %% not background\n", 100.0 * min_fraction);
    ok = false;
  }
  if (histogram.size() < min_colours) {
    std::printf("FAIL: expected at least %zu colours\n", min_colours);
    ok = false;
  }
  return ok ? 0 : 1;
}
