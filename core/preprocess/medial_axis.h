// The discrete medial axis of the object and of its complement, from the feature transform.
// Two 6-adjacent voxels of the same phase whose nearest opposite-phase voxels (features) a, b
// lie far apart (|a − b| ≥ λ) and in clearly different directions (angle ≥ θ) straddle the
// medial axis; the one nearer the bisector of a and b is marked. λ and θ filter out the short
// spurious branches that the voxel staircase would otherwise create. Defaults chosen on the
// sphere/torus phantoms (tests/test_preprocess.cpp): smaller λ or θ let staircase noise through.
#pragma once

#include <cstdint>

#include "base/progress.h"
#include "base/volume.h"

namespace cvt {

struct MedialAxisOptions {
  double min_separation_mm = 0;  // λ (mm); 0 = auto: 3 sizing units (object_scale.h)
  double min_angle_deg = 120;    // θ (degrees) between the two feature directions
};

// 0 = not medial, 1 = inner medial axis (object voxel), 2 = outer medial axis (background voxel).
// nearest_opposite: for every voxel the linear index of the nearest voxel of the other phase.
// options.min_separation_mm must be resolved (> 0). Checks progress for a cancel every k-slice.
Mask compute_medial_axis(const Mask& object, const Volume<std::int32_t>& nearest_opposite,
                         const MedialAxisOptions& options, const Progress& progress = {});

// λ in use: the option, or 3 × sizing_unit_mm when it is 0.
double effective_min_separation_mm(const MedialAxisOptions& options, double sizing_unit_mm);

}  // namespace cvt
