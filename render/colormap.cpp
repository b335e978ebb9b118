#include "colormap.h"

#include <algorithm>
#include <cmath>

namespace cvt::render {
namespace {

using Anchor = std::array<float, 3>;

// Samples of matplotlib's viridis at t = 0, 1/8, …, 1; linear interpolation between them stays
// within a few 1/255 of the full table.
constexpr Anchor kViridis[] = {
    {0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.254f, 0.265f, 0.530f},
    {0.207f, 0.372f, 0.553f}, {0.164f, 0.471f, 0.558f}, {0.128f, 0.567f, 0.551f},
    {0.135f, 0.659f, 0.518f}, {0.267f, 0.749f, 0.441f}, {0.478f, 0.821f, 0.318f},
    {0.741f, 0.873f, 0.150f}, {0.993f, 0.906f, 0.144f}};
// ColorBrewer RdYlGn (11 classes), red = low.
constexpr Anchor kRedYellowGreen[] = {
    {0.647f, 0.000f, 0.149f}, {0.843f, 0.188f, 0.153f}, {0.957f, 0.427f, 0.263f},
    {0.992f, 0.682f, 0.380f}, {0.996f, 0.878f, 0.545f}, {1.000f, 1.000f, 0.749f},
    {0.851f, 0.937f, 0.545f}, {0.651f, 0.851f, 0.416f}, {0.400f, 0.741f, 0.388f},
    {0.102f, 0.596f, 0.314f}, {0.000f, 0.408f, 0.216f}};
// Moreland's cool-warm.
constexpr Anchor kCoolwarm[] = {{0.230f, 0.299f, 0.754f},
                                {0.553f, 0.690f, 0.996f},
                                {0.865f, 0.865f, 0.865f},
                                {0.958f, 0.603f, 0.482f},
                                {0.706f, 0.016f, 0.150f}};

template <std::size_t N>
Rgba8 interpolate(const Anchor (&anchors)[N], double t) {
  const double x = std::clamp(t, 0.0, 1.0) * double(N - 1);
  const std::size_t i = std::min(std::size_t(x), N - 2);
  const double f = x - double(i);
  Rgba8 c;
  std::uint8_t* out[3] = {&c.r, &c.g, &c.b};
  for (int k = 0; k < 3; ++k) {
    const double v = anchors[i][k] * (1 - f) + anchors[i + 1][k] * f;
    *out[k] = std::uint8_t(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
  }
  return c;
}

// HSV (all in [0, 1]) → RGB bytes.
Rgba8 hsv(double h, double s, double v) {
  const double hh = (h - std::floor(h)) * 6.0;
  const int sector = int(hh) % 6;
  const double f = hh - std::floor(hh);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (sector) {
    case 0:
      r = v, g = t, b = p;
      break;
    case 1:
      r = q, g = v, b = p;
      break;
    case 2:
      r = p, g = v, b = t;
      break;
    case 3:
      r = p, g = q, b = v;
      break;
    case 4:
      r = t, g = p, b = v;
      break;
    default:
      r = v, g = p, b = q;
      break;
  }
  auto byte = [](double x) { return std::uint8_t(std::lround(std::clamp(x, 0.0, 1.0) * 255)); };
  return {byte(r), byte(g), byte(b), 255};
}

}  // namespace

std::string_view colormap_name(Colormap map) {
  switch (map) {
    case Colormap::Viridis:
      return "viridis";
    case Colormap::RedYellowGreen:
      return "red-yellow-green";
    case Colormap::Coolwarm:
      return "coolwarm";
  }
  return "?";
}

Rgba8 colormap_color(Colormap map, double t) {
  if (std::isnan(t)) return {128, 128, 128, 255};
  switch (map) {
    case Colormap::Viridis:
      return interpolate(kViridis, t);
    case Colormap::RedYellowGreen:
      return interpolate(kRedYellowGreen, t);
    case Colormap::Coolwarm:
      return interpolate(kCoolwarm, t);
  }
  return {};
}

double normalize_value(double value, double lo, double hi) {
  if (std::isnan(value)) return value;
  if (!(hi > lo)) return 0.5;
  return std::clamp((value - lo) / (hi - lo), 0.0, 1.0);
}

Rgba8 label_color(std::int64_t label) {
  if (label < 0) return {0, 0, 0, 0};
  // Golden-ratio hue steps keep consecutive labels far apart on the colour wheel; a hashed
  // saturation/value jitter separates labels whose hues happen to come close.
  const double golden = 0.6180339887498949;
  const double h = std::fmod(0.11 + double(label) * golden, 1.0);
  std::uint64_t x = std::uint64_t(label) * 0x9E3779B97F4A7C15ull;
  x ^= x >> 29;
  const double s = 0.55 + 0.35 * double((x >> 8) & 0xff) / 255.0;
  const double v = 0.75 + 0.25 * double((x >> 16) & 0xff) / 255.0;
  return hsv(h, s, v);
}

Rgba8 blend_over(Rgba8 base, Rgba8 top) {
  const int a = top.a;
  auto mix = [a](int b, int t) { return std::uint8_t((t * a + b * (255 - a) + 127) / 255); };
  const int out_a = a + base.a * (255 - a) / 255;
  return {mix(base.r, top.r), mix(base.g, top.g), mix(base.b, top.b), std::uint8_t(out_a)};
}

double luma(Rgba8 c) {
  return (0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b) / 255.0;
}

}  // namespace cvt::render
