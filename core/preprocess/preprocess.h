// Stage 1 (paper III-B): from the image and the label choice to the binary object, its smoothed
// indicator, distance and feature transforms, medial axis and local feature size.
#pragma once

#include <cstdint>
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
  Volume<float> distance_mm;              // distance to the nearest voxel of the other phase
  Volume<std::int32_t> nearest_opposite;  // that voxel's linear index (feature transform)
  Mask medial_axis;                       // 1 inner, 2 outer medial axis
  Volume<float> lfs_mm;                   // clamped local feature size
  std::vector<std::int32_t> boundary;     // F: object voxels with a background 6-neighbour
  CleanupReport cleanup;
  double smoothing_sigma_mm = 0;          // effective values after resolving "auto"
  double medial_min_separation_mm = 0;
  LfsBounds lfs_bounds{0, 0};
  std::vector<StepTime> steps;
};

double effective_smoothing_sigma_mm(double sigma_mm, const Grid& grid);

// Object voxels with at least one background 6-neighbour (voxels on the crop border count as
// having one).
std::vector<std::int32_t> boundary_voxels(const Mask& object);

PreprocessResult preprocess(const Image& image, const PreprocessOptions& options,
                            const Progress& progress = {});

}  // namespace cvt
