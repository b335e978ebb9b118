// Local feature size: the distance (mm) from every voxel to the nearest medial-axis voxel,
// inner or outer, clamped to [min, max] because lfs collapses in thin parts and is unbounded
// where the medial axis is far away.
#pragma once

#include "base/progress.h"
#include "base/volume.h"
#include "fields/distance_transform.h"

namespace cvt {

struct LfsOptions {
  double min_mm = 0;  // lower clamp (mm); 0 = auto: the largest voxel spacing (below it the
                      // image carries no shape)
  double max_mm = 0;  // upper clamp (mm); 0 = auto: 10 sizing units (object_scale.h), so
                      // broad, flat parts are still sampled
};

struct LfsBounds {
  double min_mm, max_mm;
};
LfsBounds effective_lfs_bounds(const LfsOptions& options, const Grid& grid, double sizing_unit_mm);

// medial_axis: non-zero on medial-axis voxels (compute_medial_axis). `work`: a feature
// transform whose memory the result may take over (see compute_feature_transform).
Volume<float> compute_local_feature_size(const Mask& medial_axis, const LfsBounds& bounds,
                                         const Progress& progress = {},
                                         FeatureTransform work = {});

}  // namespace cvt
