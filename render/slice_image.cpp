#include "slice_image.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>

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
  static const std::vector<std::string> names{"object",  "lfs",   "medial",  "samples",
                                              "interior", "shallow", "poles", "voronoi",
                                              "voxel-samples"};
  return names;
}

bool set_overlay(Overlays& o, const std::string& name, bool on) {
  bool* flags[] = {&o.object,   &o.lfs,     &o.medial, &o.samples,     &o.interior,
                   &o.shallow,  &o.poles,   &o.voronoi, &o.voxel_samples};
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
  return axis == 0   ? std::array<int, 2>{1, 2}
         : axis == 1 ? std::array<int, 2>{0, 2}
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
      if (!vol.object->data[lin]) continue;
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

int slice_upsample(int width, int height) {
  const int longest = std::max({width, height, 1});
  return std::clamp((1000 + longest - 1) / longest, 1, 8);
}

SliceImage compose_slice(const Image& image, const VolumeLayers* vol,
                         const std::vector<std::int32_t>* voronoi, int axis, int index,
                         const Overlays& overlays, const WindowLevel& wl, int upsample) {
  const Grid& g = image.grid();
  const auto [ua, va] = slice_plane_axes(axis);
  const int w = g.dims[ua], h = g.dims[va];
  const int k = upsample > 0 ? upsample : slice_upsample(w, h);
  SliceImage out;
  out.width = w * k;
  out.height = h * k;
  out.upsample = k;
  out.pixel_mm[0] = g.spacing[ua] / k;
  out.pixel_mm[1] = g.spacing[va] / k;
  out.pixels.assign(std::size_t(out.width) * out.height, Rgba8{0, 0, 0, 255});
  if (index < 0 || index >= g.dims[axis]) return out;

  // Per voxel: its colour, and the two things whose changes between neighbours are lines.
  std::vector<Rgba8> color(std::size_t(w) * h);
  std::vector<std::uint8_t> inside(std::size_t(w) * h, 0);
  std::vector<std::int32_t> cell(std::size_t(w) * h, -1);
  const double lo = wl.level - 0.5 * wl.window, inv_w = 1.0 / std::max(wl.window, 1e-12);
  const int ci = vol ? index - vol->offset[axis] : -1;
  const bool crop_slice = vol && ci >= 0 && ci < vol->grid.dims[axis];
  const double lfs_lo = vol ? vol->lfs_bounds.min_mm : 0, lfs_hi = vol ? vol->lfs_bounds.max_mm : 1;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const std::size_t p = std::size_t(v) * w + u;
      const auto ijk = voxel_of(axis, index, u, v);
      const double t = std::clamp((image.voxels.at(ijk[0], ijk[1], ijk[2]) - lo) * inv_w, 0.0, 1.0);
      const auto grey = std::uint8_t(std::lround(t * 255));
      Rgba8 px{grey, grey, grey, 255};
      if (crop_slice) {
        std::array<int, 3> c{};
        c[axis] = ci;
        c[ua] = u - vol->offset[ua];
        c[va] = v - vol->offset[va];
        if (vol->grid.contains(c[0], c[1], c[2])) {
          const std::size_t lin = vol->grid.linear(c[0], c[1], c[2]);
          inside[p] = vol->object->data[lin] != 0;
          if (inside[p] && overlays.object) px = blend_over(px, kObjectTint);
          if (inside[p] && overlays.lfs) {
            Rgba8 lc = colormap_color(Colormap::Viridis,
                                      normalize_value(vol->lfs_mm->data[lin], lfs_lo, lfs_hi));
            lc.a = kLfsAlpha;
            px = blend_over(px, lc);
          }
          if (inside[p] && overlays.voronoi && voronoi && (*voronoi)[p] >= 0) {
            cell[p] = (*voronoi)[p];
            Rgba8 cc = label_color(cell[p]);
            cc.a = kCellAlpha;
            px = blend_over(px, cc);
          }
          if (overlays.medial && vol->medial_axis->data[lin])
            px = vol->medial_axis->data[lin] == 1 ? kInnerMedial : kOuterMedial;
        }
      }
      color[p] = px;
    }

  // Expand; a pixel on a voxel edge whose neighbour across it differs becomes a line.
  // Beyond the slice's edge counts as outside the object and in no cell.
  auto differs = [&](const auto& field, int u, int v, int du, int dv) {
    using T = std::decay_t<decltype(field[0])>;
    const int nu = u + du, nv = v + dv;
    const T none = std::is_signed_v<T> ? T(-1) : T(0);
    const T there = nu < 0 || nv < 0 || nu >= w || nv >= h ? none : field[std::size_t(nv) * w + nu];
    return there != field[std::size_t(v) * w + u];
  };
  const bool cells = overlays.voronoi && voronoi, outline = overlays.object && crop_slice;
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const int u = x / k, v = y / k, a = x % k, b = y % k;
      Rgba8 px = color[std::size_t(v) * w + u];
      const int du = a == 0 ? -1 : a == k - 1 ? 1 : 0, dv = b == 0 ? -1 : b == k - 1 ? 1 : 0;
      // With k = 1 every pixel is on all four edges; with k ≥ 2 only the rim pixels are.
      auto on_line = [&](const auto& field) {
        if (k == 1)
          return differs(field, u, v, 1, 0) || differs(field, u, v, -1, 0) ||
                 differs(field, u, v, 0, 1) || differs(field, u, v, 0, -1);
        return (du && differs(field, u, v, du, 0)) || (dv && differs(field, u, v, 0, dv));
      };
      if (cells && cell[std::size_t(v) * w + u] >= 0 && on_line(cell))
        px = blend_over(px, kCellBorder);
      if (outline && inside[std::size_t(v) * w + u] && on_line(inside)) px = kObjectOutline;
      out.pixels[std::size_t(y) * out.width + x] = px;
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
    out.push_back(
        {float(idx[ua] * image_grid.spacing[ua]), float(idx[va] * image_grid.spacing[va]), color});
  }
}

}  // namespace cvt::render
