// Colours for scalar fields and labels, shared by the slice images, the 3D view and the legends
// (GL-free, so tests check them without a window).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace cvt::render {

// 8-bit RGBA, the layout of the slice textures and the vertex colours.
struct Rgba8 {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
  bool operator==(const Rgba8&) const = default;
};

enum class Colormap {
  Viridis,         // perceptually uniform, dark blue → yellow (lfs field)
  RedYellowGreen,  // bad → good, for quality measures where larger is better
  Coolwarm,        // blue → white → red (diverging)
};

std::string_view colormap_name(Colormap map);

// The colour at t ∈ [0, 1] (clamped; NaN gives mid grey), opaque.
Rgba8 colormap_color(Colormap map, double t);

// Maps [lo, hi] onto [0, 1] (clamped); lo == hi maps to 0.5.
double normalize_value(double value, double lo, double hi);

// A colour per integer label (e.g. a Voronoi cell's site), saturated and bright enough to read
// over grey, and different for consecutive labels; label −1 is transparent.
Rgba8 label_color(std::int64_t label);

// Blends `top` over `base` with top's alpha (straight alpha); the result is opaque if base was.
Rgba8 blend_over(Rgba8 base, Rgba8 top);

// Perceived lightness (0–1) of a colour (Rec. 709 luma of the sRGB values), for tests and for
// picking a readable border colour.
double luma(Rgba8 c);

}  // namespace cvt::render
