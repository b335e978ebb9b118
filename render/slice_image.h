// The 2D slice view's picture, composed on the CPU: the image under a window/level, then the
// switched-on overlays (object, lfs colormap, discrete Voronoi cells with borders, medial axis),
// and the samples near the slice as points. GL-free: the GL side only uploads the pixels.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "colormap.h"
#include "scene_data.h"

namespace cvt::render {

// Overlays of the slice view (and the points of the 3D view).
struct Overlays {
  bool object = true;    // tint of the object voxels with their outline
  bool lfs = false;      // local feature size colormap (inside the object)
  bool medial = false;   // medial-axis voxels (inner magenta, outer cyan)
  bool samples = true;   // surface samples B
  bool interior = true;  // interior samples I (current Lloyd sites)
  bool shallow = true;   // removed shallow points (red)
  bool poles = false;    // exterior poles EP
  bool voronoi = false;  // discrete Voronoi cells of the current Lloyd iteration
  bool voxel_samples = false;  // B at their voxel centres, before projection (slice view)
  bool operator==(const Overlays&) const = default;
};

// Sets the overlay called `name` (object, lfs, medial, samples, interior, shallow, poles,
// voronoi, voxel-samples); false for an unknown name.
bool set_overlay(Overlays& overlays, const std::string& name, bool on);
const std::vector<std::string>& overlay_names();

struct WindowLevel {
  double window = 255;   // grey ramp width (image units)
  double level = 127.5;  // grey ramp centre
  bool operator==(const WindowLevel&) const = default;
};
WindowLevel default_window_level(const ValueRange& range);

// The two in-plane axes of a slice along `axis`, lower first (the order core's slice_labels
// uses): 0 → (1, 2), 1 → (0, 2), 2 → (0, 1).
std::array<int, 2> slice_plane_axes(int axis);

struct SliceImage {
  int width = 0, height = 0;    // pixels along u (columns) and v (rows)
  int upsample = 1;             // pixels per voxel along each axis
  double pixel_mm[2] = {1, 1};  // pixel size along u and v (voxel spacing / upsample)
  std::vector<Rgba8> pixels;    // row-major, row 0 first (v = 0 at the top of the view)
};

// Pixels per voxel for a slice of width × height voxels: enough that cell borders and the
// object outline can be thin lines between voxels (about 1000 pixels across, at most 8).
int slice_upsample(int width, int height);

// Discrete Voronoi labels of the crop-grid voxels in image slice `index` along `axis` (the
// owning site, −1 outside the object or the crop), width × height of the image slice.
std::vector<std::int32_t> voronoi_slice_labels(const LloydState& lloyd, const VolumeLayers& vol,
                                               const Grid& image_grid, int axis, int index);

// Composes slice `index` along `axis` of the image grid, each voxel `upsample` × `upsample`
// pixels (0 = slice_upsample); the object outline and the Voronoi cell borders are drawn on
// the voxel edges between differing neighbours. `volumes` and `voronoi` may be null.
SliceImage compose_slice(const Image& image, const VolumeLayers* volumes,
                         const std::vector<std::int32_t>* voronoi, int axis, int index,
                         const Overlays& overlays, const WindowLevel& window_level,
                         int upsample = 0);

// A point to draw in the slice view: slice mm (u·su, v·sv: voxel centres at whole multiples of
// the spacing) and colour.
struct SlicePoint {
  float u_mm = 0, v_mm = 0;
  Rgba8 color;
};
// The world points within half_thickness voxels of the slice, placed in the slice plane.
void append_points_near_slice(const std::vector<Vec3>& world, const Grid& image_grid, int axis,
                              int index, double half_thickness_voxels, Rgba8 color,
                              std::vector<SlicePoint>& out);

// The standard colours of each kind of point (shared with the 3D view and the legend).
inline constexpr Rgba8 kSampleColor{250, 200, 60, 255};    // B: amber
inline constexpr Rgba8 kVoxelSampleColor{160, 110, 40, 255};  // B before projection: brown
inline constexpr Rgba8 kInteriorColor{70, 150, 255, 255};  // I: blue
inline constexpr Rgba8 kShallowColor{235, 40, 40, 255};    // shallow: red
inline constexpr Rgba8 kPoleColor{190, 90, 255, 255};      // EP: violet

}  // namespace cvt::render
