#include "preprocess/object_selection.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "base/errors.h"

namespace cvt {

std::vector<std::int64_t> parse_label_list(const std::string& text) {
  std::vector<std::int64_t> labels;
  if (text.empty() || text == "all") return labels;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      labels.push_back(std::stoll(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InputError("--labels: '" + item + "' is not an integer label (use 'all' or L1,L2,...)");
    }
  }
  return labels;
}

std::string describe(const ObjectSelection& s) {
  std::ostringstream out;
  if (s.iso) {
    out << "value " << (s.inside_above ? ">= " : "<= ") << *s.iso;
  } else if (s.labels.empty()) {
    out << "all non-zero labels";
  } else {
    out << "label" << (s.labels.size() > 1 ? "s " : " ");
    for (std::size_t i = 0; i < s.labels.size(); ++i) out << (i ? "," : "") << s.labels[i];
  }
  return out.str();
}

namespace {

// Per-voxel membership test for the selection.
struct InsideTest {
  const ObjectSelection& s;
  bool operator()(float v) const {
    if (s.iso) return s.inside_above ? v >= *s.iso : v <= *s.iso;
    if (s.labels.empty()) return v != 0.0f;
    const auto label = std::int64_t(std::llround(v));
    return std::find(s.labels.begin(), s.labels.end(), label) != s.labels.end();
  }
};

}  // namespace

Mask select_object(const Image& image, const ObjectSelection& selection) {
  const Grid& g = image.grid();
  const std::string name = image.source.empty() ? std::string("image") : image.source;
  if (!image.integer_valued && !selection.iso)
    throw InputError(name + ": is a grey (" + image.pixel_type +
                     ") image; choose the object with an iso value (--iso V)");
  const auto& v = image.voxels.data;
  // One parallel pass over the image: whether it holds a non-finite value, and the bounding box
  // of the selected voxels (each k-slab's own, merged; min and max do not depend on order).
  struct Scan {
    bool finite = true;
    std::array<int, 3> lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                          std::numeric_limits<int>::max()};
    std::array<int, 3> hi{-1, -1, -1};
    void merge(const Scan& o) {
      finite = finite && o.finite;
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], o.lo[a]), hi[a] = std::max(hi[a], o.hi[a]);
    }
  };
  InsideTest inside{selection};
  const Scan scan = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, g.dims[2]), Scan{},
      [&](const tbb::blocked_range<int>& r, Scan acc) {
        for (int k = r.begin(); k != r.end(); ++k)
          for (int j = 0; j < g.dims[1]; ++j) {
            const float* row = &v[g.linear(0, j, k)];
            for (int i = 0; i < g.dims[0]; ++i) {
              if (!std::isfinite(row[i])) acc.finite = false;
              if (inside(row[i])) {
                acc.lo = {std::min(acc.lo[0], i), std::min(acc.lo[1], j), std::min(acc.lo[2], k)};
                acc.hi = {std::max(acc.hi[0], i), std::max(acc.hi[1], j), std::max(acc.hi[2], k)};
              }
            }
          }
        return acc;
      },
      [](Scan a, const Scan& b) {
        a.merge(b);
        return a;
      });
  if (!scan.finite) throw InputError(name + ": holds NaN or infinite values");
  const std::array<int, 3>& lo = scan.lo;
  const std::array<int, 3>& hi = scan.hi;
  if (hi[0] < 0) throw InputError(name + ": no voxel matches " + describe(selection));

  const int m = std::max(1, selection.margin_voxels);  // ≥ 1 so the object is always closed
  std::array<int, 3> offset, dims;
  for (int a = 0; a < 3; ++a) {
    offset[a] = lo[a] - m;
    dims[a] = hi[a] - lo[a] + 1 + 2 * m;
  }
  Mask mask(g.sub_grid(offset, dims), 0);
  tbb::parallel_for(0, dims[2], [&](int k) {
    const int sk = k + offset[2];
    if (sk < 0 || sk >= g.dims[2]) return;
    for (int j = 0; j < dims[1]; ++j) {
      const int sj = j + offset[1];
      if (sj < 0 || sj >= g.dims[1]) continue;
      for (int i = 0; i < dims[0]; ++i) {
        const int si = i + offset[0];
        if (si >= 0 && si < g.dims[0] && inside(v[g.linear(si, sj, sk)])) mask.at(i, j, k) = 1;
      }
    }
  });
  return mask;
}

}  // namespace cvt
