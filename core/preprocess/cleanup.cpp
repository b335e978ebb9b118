#include "preprocess/cleanup.h"

#include <algorithm>
#include <numeric>

namespace cvt {
namespace {

// A maximal run of equal voxels along i in row (j, k): voxels [i0, i1).
struct Run {
  int i0, i1, j, k;
};

// Runs of voxels equal to `value`, row by row (k outer, j inner), and the index of each row's
// first run, so neighbouring rows can be matched.
struct Runs {
  std::vector<Run> runs;
  std::vector<std::size_t> row_start;  // size rows + 1
};

Runs find_runs(const Mask& mask, unsigned char value) {
  const Grid& g = mask.grid;
  Runs r;
  r.row_start.reserve(std::size_t(g.dims[1]) * g.dims[2] + 1);
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j) {
      r.row_start.push_back(r.runs.size());
      const unsigned char* row = &mask.data[g.linear(0, j, k)];
      for (int i = 0; i < g.dims[0];) {
        if (row[i] != value) {
          ++i;
          continue;
        }
        const int i0 = i;
        while (i < g.dims[0] && row[i] == value) ++i;
        r.runs.push_back({i0, i, j, k});
      }
    }
  r.row_start.push_back(r.runs.size());
  return r;
}

int find_root(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// 6-connected components of runs: runs in rows (j−1, k) and (j, k−1) that overlap along i are
// joined. Returns the component id (0..n−1, in scan order) of every run.
std::vector<int> run_components(const Mask& mask, const Runs& r, int& count) {
  const Grid& g = mask.grid;
  std::vector<int> parent(r.runs.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto join_rows = [&](std::size_t row, std::size_t other) {
    std::size_t a = r.row_start[row], b = r.row_start[other];
    const std::size_t a_end = r.row_start[row + 1], b_end = r.row_start[other + 1];
    while (a < a_end && b < b_end) {  // merge walk over two sorted run lists
      const Run &x = r.runs[a], &y = r.runs[b];
      if (x.i0 < y.i1 && y.i0 < x.i1) {
        const int ra = find_root(parent, int(a)), rb = find_root(parent, int(b));
        if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
      }
      (x.i1 < y.i1) ? ++a : ++b;
    }
  };
  const std::size_t ny = std::size_t(g.dims[1]);
  for (std::size_t row = 0; row + 1 < r.row_start.size(); ++row) {
    if (row % ny) join_rows(row, row - 1);
    if (row >= ny) join_rows(row, row - ny);
  }
  std::vector<int> id(r.runs.size()), root_id(r.runs.size(), -1);
  count = 0;
  for (std::size_t i = 0; i < r.runs.size(); ++i) {
    const int root = find_root(parent, int(i));
    if (root_id[root] < 0) root_id[root] = count++;
    id[i] = root_id[root];
  }
  return id;
}

bool touches_border(const Grid& g, const Run& run) {
  return run.i0 == 0 || run.i1 == g.dims[0] || run.j == 0 || run.j == g.dims[1] - 1 ||
         run.k == 0 || run.k == g.dims[2] - 1;
}

void fill(Mask& mask, const Run& run, unsigned char value) {
  unsigned char* row = &mask.data[mask.grid.linear(0, run.j, run.k)];
  std::fill(row + run.i0, row + run.i1, value);
}

}  // namespace

std::vector<std::size_t> label_components(const Mask& mask, unsigned char value,
                                          std::vector<int>& labels) {
  const Runs r = find_runs(mask, value);
  int count = 0;
  const std::vector<int> id = run_components(mask, r, count);
  std::vector<std::size_t> sizes(std::size_t(count), 0);
  labels.assign(mask.size(), 0);
  for (std::size_t i = 0; i < r.runs.size(); ++i) {
    const Run& run = r.runs[i];
    sizes[id[i]] += std::size_t(run.i1 - run.i0);
    int* row = &labels[mask.grid.linear(0, run.j, run.k)];
    std::fill(row + run.i0, row + run.i1, id[i] + 1);
  }
  return sizes;
}

CleanupReport clean_object(Mask& mask, const CleanupOptions& options) {
  CleanupReport report;
  std::size_t object_voxels = 0;  // after the specks are dropped
  // Object components: sizes from their runs; small ones are cleared run by run.
  {
    const Runs r = find_runs(mask, 1);
    int count = 0;
    const std::vector<int> id = run_components(mask, r, count);
    std::vector<std::size_t> size(std::size_t(count), 0);
    for (std::size_t i = 0; i < r.runs.size(); ++i) size[id[i]] += std::size_t(r.runs[i].i1 - r.runs[i].i0);
    report.components = count;
    if (options.remove_small_components && count > 0) {
      const double keep_from =
          options.min_component_fraction * double(*std::max_element(size.begin(), size.end()));
      std::vector<char> drop(std::size_t(count), 0);
      for (int c = 0; c < count; ++c)
        if (double(size[c]) < keep_from) {
          drop[c] = 1;
          ++report.components_removed;
          report.voxels_removed += size[c];
        }
      for (std::size_t i = 0; i < r.runs.size(); ++i)
        if (drop[id[i]]) fill(mask, r.runs[i], 0);
    }
    for (std::size_t s : size) object_voxels += s;
    object_voxels -= report.voxels_removed;
  }
  // Cavities: background components that do not reach the border of the (padded) crop; the
  // small ones are filled.
  if (options.fill_cavities) {
    const Runs r = find_runs(mask, 0);
    int count = 0;
    const std::vector<int> id = run_components(mask, r, count);
    std::vector<char> outside(std::size_t(count), 0);
    std::vector<std::size_t> size(std::size_t(count), 0);
    for (std::size_t i = 0; i < r.runs.size(); ++i) {
      size[id[i]] += std::size_t(r.runs[i].i1 - r.runs[i].i0);
      if (touches_border(mask.grid, r.runs[i])) outside[id[i]] = 1;
    }
    const double fill_up_to = options.max_cavity_fraction * double(object_voxels);
    std::vector<char> filled(std::size_t(count), 0);
    for (int c = 0; c < count; ++c) {
      if (outside[c]) continue;
      filled[c] = double(size[c]) <= fill_up_to;
      ++(filled[c] ? report.cavities_filled : report.cavities_kept);
      (filled[c] ? report.voxels_filled : report.voxels_kept) += size[c];
    }
    for (std::size_t i = 0; i < r.runs.size(); ++i)
      if (filled[id[i]]) fill(mask, r.runs[i], 1);
  }
  return report;
}

}  // namespace cvt
