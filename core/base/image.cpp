#include "base/image.h"

#include <algorithm>
#include <cmath>

namespace cvt {

ValueRange value_range(const Image& image) {
  // NaN/Inf voxels are skipped: with them, minmax_element's answer depends on where they are.
  float lo = INFINITY, hi = -INFINITY;
  for (float v : image.voxels.data)
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  if (lo > hi) return {};
  return {lo, hi};
}

std::map<std::int64_t, std::size_t> label_histogram(const Image& image) {
  std::map<std::int64_t, std::size_t> histogram;
  if (!image.integer_valued) return histogram;
  // Dense counting for the usual small label range, a map otherwise.
  const ValueRange r = value_range(image);
  if (r.min >= 0 && r.max < 65536) {
    std::vector<std::size_t> counts(std::size_t(r.max) + 1, 0);
    for (float v : image.voxels.data) ++counts[std::size_t(v)];
    for (std::size_t l = 0; l < counts.size(); ++l)
      if (counts[l]) histogram[std::int64_t(l)] = counts[l];
  } else {
    for (float v : image.voxels.data) ++histogram[std::int64_t(std::llround(v))];
  }
  return histogram;
}

}  // namespace cvt
