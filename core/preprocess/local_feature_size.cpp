#include "preprocess/local_feature_size.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

namespace cvt {

LfsBounds effective_lfs_bounds(const LfsOptions& options, const Grid& g, double sizing_unit_mm) {
  LfsBounds b{options.min_mm, options.max_mm};
  if (b.min_mm <= 0) b.min_mm = std::max({g.spacing.x, g.spacing.y, g.spacing.z});
  if (b.max_mm <= 0) b.max_mm = 10.0 * sizing_unit_mm;
  b.max_mm = std::max(b.max_mm, b.min_mm);
  return b;
}

Volume<float> compute_local_feature_size(const Mask& medial_axis, const LfsBounds& bounds,
                                         const Progress& progress, FeatureTransform work) {
  compute_feature_transform(medial_axis, work, /*compute_nearest=*/false, progress);
  Volume<float> lfs = std::move(work.squared_distance_mm2);
  const float lo = float(bounds.min_mm), hi = float(bounds.max_mm);
  tbb::parallel_for(std::size_t(0), lfs.size(), [&](std::size_t v) {
    const float d2 = lfs.data[v];
    lfs.data[v] = std::isfinite(d2) ? std::clamp(std::sqrt(d2), lo, hi) : hi;
  });
  return lfs;
}

}  // namespace cvt
