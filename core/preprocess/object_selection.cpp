#include "preprocess/object_selection.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <tbb/parallel_for.h>

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
  for (float x : v)
    if (!std::isfinite(x)) throw InputError(name + ": holds NaN or infinite values");

  // Bounding box of the selected voxels.
  InsideTest inside{selection};
  std::array<int, 3> lo{g.dims[0], g.dims[1], g.dims[2]}, hi{-1, -1, -1};
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j) {
      const float* row = &v[g.linear(0, j, k)];
      for (int i = 0; i < g.dims[0]; ++i)
        if (inside(row[i])) {
          lo = {std::min(lo[0], i), std::min(lo[1], j), std::min(lo[2], k)};
          hi = {std::max(hi[0], i), std::max(hi[1], j), std::max(hi[2], k)};
        }
    }
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
