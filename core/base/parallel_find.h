// The first index that satisfies a test, found on all cores with the answer of a serial scan.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstddef>

namespace cvt {

// The least i in [0, n) with hit(i) true, or n. Every index below the answer is tested once, so
// `hit` may also do each index's work (a conversion, say) as it tests; beyond the answer, some
// indices are tested and others not. Ranges of at least `grain` indices go to the threads.
template <class Hit>
std::size_t parallel_find_first(std::size_t n, Hit hit, std::size_t grain = 1) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, grain), n,
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t first) {
        for (std::size_t i = r.begin(); i < r.end() && i < first; ++i)
          if (hit(i)) return i;
        return first;
      },
      [](std::size_t a, std::size_t b) { return std::min(a, b); });
}

}  // namespace cvt
