#include "cleanup.h"

#include <algorithm>
#include <array>

namespace cvt {

std::vector<std::size_t> label_components(const Mask& mask, unsigned char value,
                                          std::vector<int>& labels) {
  const Grid& g = mask.grid;
  const int nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const std::ptrdiff_t sx = 1, sy = nx, sz = std::ptrdiff_t(nx) * ny;
  labels.assign(mask.size(), 0);
  std::vector<std::size_t> sizes;
  std::vector<std::ptrdiff_t> stack;
  for (std::size_t seed = 0; seed < mask.size(); ++seed) {
    if (mask.data[seed] != value || labels[seed]) continue;
    const int id = int(sizes.size()) + 1;
    std::size_t count = 0;
    labels[seed] = id;
    stack.assign(1, std::ptrdiff_t(seed));
    while (!stack.empty()) {
      const std::ptrdiff_t v = stack.back();
      stack.pop_back();
      ++count;
      const auto c = g.ijk(std::size_t(v));
      const std::array<std::pair<bool, std::ptrdiff_t>, 6> next{{{c[0] > 0, -sx},
                                                                 {c[0] < nx - 1, sx},
                                                                 {c[1] > 0, -sy},
                                                                 {c[1] < ny - 1, sy},
                                                                 {c[2] > 0, -sz},
                                                                 {c[2] < nz - 1, sz}}};
      for (auto [ok, step] : next) {
        if (!ok) continue;
        const std::ptrdiff_t n = v + step;
        if (mask.data[n] == value && !labels[n]) {
          labels[n] = id;
          stack.push_back(n);
        }
      }
    }
    sizes.push_back(count);
  }
  return sizes;
}

namespace {

bool on_border(const Grid& g, std::size_t v) {
  const auto c = g.ijk(v);
  for (int a = 0; a < 3; ++a)
    if (c[a] == 0 || c[a] == g.dims[a] - 1) return true;
  return false;
}

}  // namespace

CleanupReport clean_object(Mask& mask, const CleanupOptions& options) {
  CleanupReport report;
  std::vector<int> labels;
  const auto sizes = label_components(mask, 1, labels);
  report.components = int(sizes.size());
  if (options.remove_small_components && !sizes.empty()) {
    const std::size_t largest = *std::max_element(sizes.begin(), sizes.end());
    const double keep_from = options.min_component_fraction * double(largest);
    std::vector<char> drop(sizes.size() + 1, 0);
    for (std::size_t c = 0; c < sizes.size(); ++c)
      if (double(sizes[c]) < keep_from) {
        drop[c + 1] = 1;
        ++report.components_removed;
        report.voxels_removed += sizes[c];
      }
    if (report.components_removed)
      for (std::size_t v = 0; v < mask.size(); ++v)
        if (drop[labels[v]]) mask.data[v] = 0;
  }
  if (options.fill_cavities) {
    const auto bg_sizes = label_components(mask, 0, labels);
    // A background component is a cavity unless it touches the border of the (padded) crop.
    std::vector<char> outside(bg_sizes.size() + 1, 0);
    for (std::size_t v = 0; v < mask.size(); ++v)
      if (labels[v] && !outside[labels[v]] && on_border(mask.grid, v)) outside[labels[v]] = 1;
    for (std::size_t c = 0; c < bg_sizes.size(); ++c)
      if (!outside[c + 1]) {
        ++report.cavities_filled;
        report.voxels_filled += bg_sizes[c];
      }
    if (report.cavities_filled)
      for (std::size_t v = 0; v < mask.size(); ++v)
        if (labels[v] && !outside[labels[v]]) mask.data[v] = 1;
  }
  return report;
}

}  // namespace cvt
