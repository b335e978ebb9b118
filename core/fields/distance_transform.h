// Exact Euclidean distance transform with anisotropic spacing and the feature transform
// (the nearest feature voxel of every voxel), in linear time (Maurer et al. 2003), parallel
// over rows with TBB. The feature transform is the discrete Voronoi diagram of the features.
#pragma once

#include <cstdint>

#include "base/progress.h"
#include "base/volume.h"

namespace cvt {

struct FeatureTransform {
  Volume<float> squared_distance_mm2;  // |x − nearest feature|² in mm²; +inf when no feature
  Volume<std::int32_t> nearest;        // linear index of the nearest feature voxel; −1 if none
};

// Features are the voxels where `features` is non-zero. Distances use features.grid.spacing.
// Ties between equidistant features are broken deterministically (independent of threads).
// compute_nearest=false skips the feature volume (its data is then left empty); the distances
// are bitwise the same either way. Checks progress for a cancel every k-slice and every tile of
// lines (throws Cancelled).
FeatureTransform compute_feature_transform(const Mask& features, bool compute_nearest = true,
                                           const Progress& progress = {});

// The same into `out`, reusing its volumes' memory when it is large enough: repeated transforms
// then skip allocating and first-touching 4–8 bytes per voxel (page faults, kernel zeroing).
// Whatever `out` held before is overwritten; compute_nearest=false empties out.nearest.data.
void compute_feature_transform(const Mask& features, FeatureTransform& out,
                               bool compute_nearest = true, const Progress& progress = {});

}  // namespace cvt
