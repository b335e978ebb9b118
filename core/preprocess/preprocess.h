// Stage 1 (paper III-B): from the image and the label choice to the binary object, its smoothed
// indicator, distance and feature transforms, medial axis and local feature size.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "preprocess/cleanup.h"
#include "base/image.h"
#include "preprocess/local_feature_size.h"
#include "preprocess/medial_axis.h"
#include "preprocess/object_selection.h"
#include "base/progress.h"

namespace cvt {

struct PreprocessOptions {
  ObjectSelection selection;
  CleanupOptions cleanup;
  double smoothing_sigma_mm = 0;  // Gaussian σ of the smoothed indicator; 0 = auto (0.5 × max spacing)
  MedialAxisOptions medial_axis;
  LfsOptions lfs;
  std::size_t max_bytes = 0;  // refuse when the estimate exceeds this; 0 = available memory
};

struct StepTime {
  std::string name;
  double wall_s = 0;
};

struct PreprocessResult {
  Mask object;                            // cropped + padded binary object (1 inside)
  Volume<float> indicator;                // smoothed object; 0.5 level = sub-voxel boundary
  Volume<std::uint16_t> nearest_opposite;  // the nearest voxel of the other phase (feature
                                           // transform) as a packed offset: nearest_opposite()
  Mask medial_axis;                       // 1 inner, 2 outer medial axis
  Volume<float> lfs_mm;                   // clamped local feature size
  std::vector<std::int32_t> boundary;     // F: object voxels with a background 6-neighbour
  CleanupReport cleanup;
  double smoothing_sigma_mm = 0;          // effective values after resolving "auto"
  double volume_to_area_mm = 0;          // the object's scale (object_scale.h)
  double sizing_unit_mm = 0;
  double medial_min_separation_mm = 0;
  LfsBounds lfs_bounds{0, 0};
  std::vector<StepTime> steps;
};

double effective_smoothing_sigma_mm(double sigma_mm, const Grid& grid);

// Object voxels with at least one background 6-neighbour (voxels on the crop border count as
// having one).
std::vector<std::int32_t> boundary_voxels(const Mask& object);

// The linear index of a nearest voxel of the other phase than voxel v's, if it lies within
// `within_mm` of v; else −1. Stage 1 keeps it as an offset of at most kNearestOppositeReach
// voxels along each axis (half the memory of an index): the few nearest voxels beyond that
// but within `within_mm`, in strongly anisotropic grids, are searched for.
constexpr int kNearestOppositeReach = 15;
std::int64_t nearest_opposite(const PreprocessResult& pre, std::size_t v, double within_mm);

PreprocessResult preprocess(const Image& image, const PreprocessOptions& options,
                            const Progress& progress = {});
// The same, holding `image` only until the object is selected: when the caller passes the
// last reference, the image's memory is free for the rest of stage 1.
PreprocessResult preprocess(std::shared_ptr<const Image> image, const PreprocessOptions& options,
                            const Progress& progress = {});

}  // namespace cvt
