#include "cleanup.h"

#include <algorithm>
#include <array>

namespace cvt {

std::vector<std::size_t> label_components(const Mask& mask, unsigned char value,
                                          std::vector<int>& labels) {
  const Grid& g = mask.grid;
  const int n[3] = {g.dims[0], g.dims[1], g.dims[2]};
  const std::ptrdiff_t step[3] = {1, n[0], std::ptrdiff_t(n[0]) * n[1]};
  labels.assign(mask.size(), 0);
  std::vector<std::size_t> sizes;
  // The stack carries coordinates with each voxel so bounds checks need no divisions.
  struct Item {
    std::ptrdiff_t v;
    int c[3];
  };
  std::vector<Item> stack;
  std::size_t seed = 0;
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i, ++seed) {
        if (mask.data[seed] != value || labels[seed]) continue;
        const int id = int(sizes.size()) + 1;
        std::size_t count = 0;
        labels[seed] = id;
        stack.push_back({std::ptrdiff_t(seed), {i, j, k}});
        while (!stack.empty()) {
          const Item item = stack.back();
          stack.pop_back();
          ++count;
          for (int a = 0; a < 3; ++a)
            for (int dir = -1; dir <= 1; dir += 2) {
              const int c = item.c[a] + dir;
              if (c < 0 || c >= n[a]) continue;
              const std::ptrdiff_t nb = item.v + dir * step[a];
              if (mask.data[nb] != value || labels[nb]) continue;
              labels[nb] = id;
              Item next = item;
              next.v = nb;
              next.c[a] = c;
              stack.push_back(next);
            }
        }
        sizes.push_back(count);
      }
  return sizes;
}

namespace {

// Marks the labels of components that reach the border of the grid.
void mark_border_labels(const Grid& g, const std::vector<int>& labels, std::vector<char>& mark) {
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j) {
      const bool face = k == 0 || j == 0 || k == g.dims[2] - 1 || j == g.dims[1] - 1;
      for (int i = 0; i < g.dims[0]; i += face ? 1 : std::max(1, g.dims[0] - 1)) {
        const int l = labels[g.linear(i, j, k)];
        if (l) mark[l] = 1;
      }
    }
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
    mark_border_labels(mask.grid, labels, outside);
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
