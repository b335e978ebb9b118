#include "slice_image.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace cvt::render {
namespace {

constexpr Rgba8 kObjectTint{70, 210, 120, 80};
constexpr Rgba8 kObjectOutline{90, 240, 140, 230};
constexpr Rgba8 kInnerMedial{255, 60, 210, 255};
constexpr Rgba8 kOuterMedial{60, 225, 255, 255};
constexpr Rgba8 kCellBorder{20, 20, 20, 230};
constexpr std::uint8_t kCellAlpha = 150;
constexpr std::uint8_t kLfsAlpha = 210;

// Image voxel (i, j, k) of slice pixel (u, v).
std::array<int, 3> voxel_of(int axis, int index, int u, int v) {
  const auto [a, b] = slice_plane_axes(axis);
  std::array<int, 3> ijk{};
  ijk[axis] = index;
  ijk[a] = u;
  ijk[b] = v;
  return ijk;
}

}  // namespace

const std::vector<std::string>& overlay_names() {
  static const std::vector<std::string> names{"object",   "lfs",     "medial", "samples",
                                              "interior", "shallow", "poles",  "voronoi"};
  return names;
}

bool set_overlay(Overlays& o, const std::string& name, bool on) {
  bool* flags[] = {&o.object,   &o.lfs,     &o.medial, &o.samples,
                   &o.interior, &o.shallow, &o.poles,  &o.voronoi};
  const auto& names = overlay_names();
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) {
      *flags[i] = on;
      return true;
    }
  return false;
}

WindowLevel default_window_level(const ValueRange& range) {
  const double w = range.max - range.min;
  return {w > 0 ? w : 1.0, 0.5 * (range.min + range.max)};
}

std::array<int, 2> slice_plane_axes(int axis) {
  return axis == 0 ? std::array<int, 2>{1, 2} : axis == 1 ? std::array<int, 2>{0, 2}
                                                          : std::array<int, 2>{0, 1};
}

std::vector<std::int32_t> voronoi_slice_labels(const LloydState& lloyd, const VolumeLayers& vol,
                                               const Grid& image_grid, int axis, int index) {
  const auto [ua, va] = slice_plane_axes(axis);
  const int width = image_grid.dims[ua], height = image_grid.dims[va];
  std::vector<std::int32_t> labels(std::size_t(width) * height, -1);
  const int crop_index = index - vol.offset[axis];
  if (crop_index < 0 || crop_index >= vol.grid.dims[axis] || lloyd.sites_local.empty())
    return labels;
  // Object voxels of the crop in this slice, and where each one lands in the image slice.
  std::vector<std::int32_t> voxels;
  std::vector<std::size_t> pixel;
  for (int cv = 0; cv < vol.grid.dims[va]; ++cv)
    for (int cu = 0; cu < vol.grid.dims[ua]; ++cu) {
      std::array<int, 3> c{};
      c[axis] = crop_index;
      c[ua] = cu;
      c[va] = cv;
      const std::size_t lin = vol.grid.linear(c[0], c[1], c[2]);
      if (!vol.object.data[lin]) continue;
      const int u = cu + vol.offset[ua], v = cv + vol.offset[va];
      if (u < 0 || v < 0 || u >= width || v >= height) continue;
      voxels.push_back(std::int32_t(lin));
      pixel.push_back(std::size_t(v) * width + u);
    }
  const std::vector<std::int32_t> owners =
      nearest_site_owners(lloyd.grid, lloyd.sites_local, voxels);
  for (std::size_t i = 0; i < owners.size(); ++i) labels[pixel[i]] = owners[i];
  return labels;
}

SliceImage compose_slice(const Image& image, const VolumeLayers* vol,
                         const std::vector<std::int32_t>* voronoi, int axis, int index,
                         const Overlays& overlays, const WindowLevel& wl) {
  const Grid& g = image.grid();
  const auto [ua, va] = slice_plane_axes(axis);
  SliceImage out;
  out.width = g.dims[ua];
  out.height = g.dims[va];
  out.pixel_mm[0] = g.spacing[ua];
  out.pixel_mm[1] = g.spacing[va];
  out.pixels.assign(std::size_t(out.width) * out.height, Rgba8{0, 0, 0, 255});
  if (index < 0 || index >= g.dims[axis]) return out;
  const double lo = wl.level - 0.5 * wl.window, inv_w = 1.0 / std::max(wl.window, 1e-12);
  for (int v = 0; v < out.height; ++v)
    for (int u = 0; u < out.width; ++u) {
      const auto ijk = voxel_of(axis, index, u, v);
      const double t = std::clamp((image.voxels.at(ijk[0], ijk[1], ijk[2]) - lo) * inv_w, 0.0, 1.0);
      const auto grey = std::uint8_t(std::lround(t * 255));
      out.pixels[std::size_t(v) * out.width + u] = {grey, grey, grey, 255};
    }
  if (!vol) return out;
  const int ci = index - vol->offset[axis];
  if (ci < 0 || ci >= vol->grid.dims[axis]) return out;
  // Crop voxel value at image slice pixel (u, v); `fallback` outside the crop.
  auto crop_lin = [&](int u, int v) -> long long {
    std::array<int, 3> c{};
    c[axis] = ci;
    c[ua] = u - vol->offset[ua];
    c[va] = v - vol->offset[va];
    if (!vol->grid.contains(c[0], c[1], c[2])) return -1;
    return (long long)vol->grid.linear(c[0], c[1], c[2]);
  };
  auto inside = [&](int u, int v) {
    const long long lin = crop_lin(u, v);
    return lin >= 0 && vol->object.data[lin] != 0;
  };
  auto label_at = [&](int u, int v) {
    if (u < 0 || v < 0 || u >= out.width || v >= out.height) return std::int32_t(-1);
    return (*voronoi)[std::size_t(v) * out.width + u];
  };
  const double lfs_lo = vol->lfs_bounds.min_mm, lfs_hi = vol->lfs_bounds.max_mm;
  for (int v = 0; v < out.height; ++v)
    for (int u = 0; u < out.width; ++u) {
      const long long lin = crop_lin(u, v);
      if (lin < 0) continue;
      Rgba8& px = out.pixels[std::size_t(v) * out.width + u];
      const bool in = vol->object.data[lin] != 0;
      if (in && overlays.object) {
        const bool edge = !inside(u - 1, v) || !inside(u + 1, v) || !inside(u, v - 1) ||
                          !inside(u, v + 1);
        px = blend_over(px, edge ? kObjectOutline : kObjectTint);
      }
      if (in && overlays.lfs) {
        Rgba8 c = colormap_color(Colormap::Viridis,
                                 normalize_value(vol->lfs_mm.data[lin], lfs_lo, lfs_hi));
        c.a = kLfsAlpha;
        px = blend_over(px, c);
      }
      if (in && overlays.voronoi && voronoi) {
        const std::int32_t label = label_at(u, v);
        if (label >= 0) {
          const bool border = label_at(u + 1, v) != label || label_at(u - 1, v) != label ||
                              label_at(u, v + 1) != label || label_at(u, v - 1) != label;
          Rgba8 c = label_color(label);
          c.a = kCellAlpha;
          px = blend_over(px, border ? kCellBorder : c);
        }
      }
      if (overlays.medial && vol->medial_axis.data[lin])
        px = vol->medial_axis.data[lin] == 1 ? kInnerMedial : kOuterMedial;
    }
  return out;
}

void append_points_near_slice(const std::vector<Vec3>& world, const Grid& image_grid, int axis,
                              int index, double half_thickness_voxels, Rgba8 color,
                              std::vector<SlicePoint>& out) {
  const auto [ua, va] = slice_plane_axes(axis);
  for (const Vec3& p : world) {
    const Vec3 idx = image_grid.world_to_index(p);
    if (std::abs(idx[axis] - index) > half_thickness_voxels) continue;
    out.push_back({float(idx[ua] * image_grid.spacing[ua]),
                   float(idx[va] * image_grid.spacing[va]), color});
  }
}

}  // namespace cvt::render
