#include "base/image.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>

namespace cvt {

ValueRange value_range(const Image& image) {
  // NaN/Inf voxels are skipped: with them, minmax_element's answer depends on where they are.
  using Range = std::pair<float, float>;
  const std::vector<float>& data = image.voxels.data;
  const auto [lo, hi] = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, data.size(), 1 << 16), Range{INFINITY, -INFINITY},
      [&](const tbb::blocked_range<std::size_t>& r, Range m) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
          if (std::isfinite(data[i]))
            m.first = std::min(m.first, data[i]), m.second = std::max(m.second, data[i]);
        return m;
      },
      [](Range a, Range b) {
        return Range{std::min(a.first, b.first), std::max(a.second, b.second)};
      });
  if (lo > hi) return {};
  return {lo, hi};
}

std::map<std::int64_t, std::size_t> label_histogram(const Image& image) {
  std::map<std::int64_t, std::size_t> histogram;
  if (!image.integer_valued) return histogram;
  // Dense counting, in parallel, for the usual small label range; a map otherwise.
  const ValueRange r = value_range(image);
  const std::vector<float>& data = image.voxels.data;
  if (r.min >= 0 && r.max < 65536) {
    // Per-thread counts (a lambda reduction would copy them for every chunk).
    const std::size_t labels = std::size_t(r.max) + 1;
    tbb::combinable<std::vector<std::size_t>> local(
        [&] { return std::vector<std::size_t>(labels, 0); });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, data.size(), 1 << 16),
                      [&](const auto& range) {
                        std::vector<std::size_t>& c = local.local();
                        for (std::size_t i = range.begin(); i != range.end(); ++i)
                          ++c[std::size_t(data[i])];
                      });
    std::vector<std::size_t> counts(labels, 0);
    local.combine_each([&](const std::vector<std::size_t>& c) {
      for (std::size_t l = 0; l < labels; ++l) counts[l] += c[l];
    });
    for (std::size_t l = 0; l < counts.size(); ++l)
      if (counts[l]) histogram[std::int64_t(l)] = counts[l];
  } else {
    for (float v : data) ++histogram[std::int64_t(std::llround(v))];
  }
  return histogram;
}

}  // namespace cvt
