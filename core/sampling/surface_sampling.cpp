#include "sampling/surface_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "base/errors.h"
#include "base/point_grid.h"
#include "fields/smoothing.h"

namespace cvt {
namespace {

// A max-heap of the items 0..n−1 by (key[i], i), each held once and moved as its key changes:
// the order a priority queue of (key, i) pairs with stale entries skipped would give, without
// the stale entries (on the liver ~0.7 M of them, four times the items).
class ItemHeap {
 public:
  explicit ItemHeap(const std::vector<double>& key) : key_(key), pos_(key.size()) {
    heap_.resize(key.size());
    for (std::size_t i = 0; i < heap_.size(); ++i) heap_[i] = std::int32_t(i);
    std::make_heap(heap_.begin(), heap_.end(), [&](std::int32_t a, std::int32_t b) { return below(a, b); });
    for (std::size_t p = 0; p < heap_.size(); ++p) pos_[std::size_t(heap_[p])] = std::int32_t(p);
  }
  bool empty() const { return heap_.empty(); }
  std::size_t size() const { return heap_.size(); }
  std::int32_t top() const { return heap_[0]; }
  // Takes item i out (the top or any other).
  void remove(std::int32_t i) {
    const std::size_t p = std::size_t(pos_[std::size_t(i)]);
    const std::int32_t last = heap_.back();
    heap_.pop_back();
    if (p == heap_.size()) return;
    place(p, last);
    changed(last);
  }
  // Item i's key changed.
  void changed(std::int32_t i) {
    const std::size_t p = std::size_t(pos_[std::size_t(i)]);
    if (p > 0 && below(heap_[(p - 1) / 2], i)) sift_up(p);
    else sift_down(p);
  }

 private:
  bool below(std::int32_t a, std::int32_t b) const {
    return key_[std::size_t(a)] < key_[std::size_t(b)] ||
           (key_[std::size_t(a)] == key_[std::size_t(b)] && a < b);
  }
  void place(std::size_t p, std::int32_t i) {
    heap_[p] = i;
    pos_[std::size_t(i)] = std::int32_t(p);
  }
  void sift_up(std::size_t p) {
    const std::int32_t i = heap_[p];
    while (p > 0 && below(heap_[(p - 1) / 2], i)) {
      place(p, heap_[(p - 1) / 2]);
      p = (p - 1) / 2;
    }
    place(p, i);
  }
  void sift_down(std::size_t p) {
    const std::int32_t i = heap_[p];
    for (;;) {
      std::size_t c = 2 * p + 1;
      if (c >= heap_.size()) break;
      if (c + 1 < heap_.size() && below(heap_[c], heap_[c + 1])) ++c;
      if (!below(i, heap_[c])) break;
      place(p, heap_[c]);
      p = c;
    }
    place(p, i);
  }

  const std::vector<double>& key_;
  std::vector<std::int32_t> heap_, pos_;
};

}  // namespace

bool project_to_level_set(const Volume<float>& field, float level, Vec3& index,
                          double max_move_voxels) {
  const Grid& g = field.grid;
  const double max_spacing = std::max({g.spacing.x, g.spacing.y, g.spacing.z});
  const double max_move_mm = max_move_voxels * max_spacing;
  const double max_step_mm = 0.5 * std::min({g.spacing.x, g.spacing.y, g.spacing.z});
  Vec3 x = index;
  for (int iteration = 0; iteration < 30; ++iteration) {
    const double f = double(sample_trilinear(field, x)) - level;
    if (std::abs(f) < 1e-4) break;
    const Vec3 grad = gradient_local(field, x);  // per mm
    const double g2 = squared_norm(grad);
    if (g2 < 1e-12) return false;
    // Newton step in mm along the gradient, damped to half a voxel (a far-off start would
    // otherwise overshoot), converted back to index units.
    Vec3 step_mm = grad * (-f / g2);
    const double len = norm(step_mm);
    if (len > max_step_mm) step_mm = step_mm * (max_step_mm / len);
    for (int a = 0; a < 3; ++a) x[a] += step_mm[a] / g.spacing[a];
    if (norm(g.index_to_local(x - index)) > max_move_mm) return false;
  }
  if (std::abs(double(sample_trilinear(field, x)) - level) > 1e-3) return false;
  index = x;
  return true;
}

double area_weighted_spacing_mm(const SurfaceSamples& samples, const Volume<float>& lfs_mm,
                                const SurfaceSamplingOptions& options) {
  double c2 = 0, c2s = 0;
  for (std::int32_t v : samples.voxels) {
    const double lfs = lfs_mm.data[v], s = options.r * lfs;
    const double c = sampling_radius_mm(lfs, options);
    c2 += c * c;
    c2s += c * c * s;
  }
  return c2 > 0 ? c2s / c2 : 0.0;
}

double median_boundary_lfs_mm(const PreprocessResult& pre) {
  std::vector<float> lfs;
  lfs.reserve(pre.boundary.size());
  for (std::int32_t v : pre.boundary) lfs.push_back(pre.lfs_mm.data[std::size_t(v)]);
  if (lfs.empty()) return 0;
  const auto mid = lfs.begin() + std::ptrdiff_t(lfs.size() / 2);
  std::nth_element(lfs.begin(), mid, lfs.end());
  return *mid;
}

SurfaceSamples sample_surface(const PreprocessResult& pre, const SurfaceSamplingOptions& options,
                              const Progress& progress) {
  if (!(options.r > 0 && options.r < 1)) throw InputError("--r: must be in (0, 1)");
  const Grid& grid = pre.object.grid;
  const std::vector<std::int32_t>& F = pre.boundary;
  const std::size_t n = F.size();
  std::vector<Vec3> pos(n);
  std::vector<double> lfs(n);
  // With a cap, the algorithm runs on lfs' = radius / r.
  const bool capped = options.chord_tolerance_mm > 0 || options.surface_lfs_max_mm > 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = grid.ijk(std::size_t(F[i]));
    pos[i] = grid.index_to_local({double(c[0]), double(c[1]), double(c[2])});
    lfs[i] = pre.lfs_mm.data[F[i]];
    if (capped) lfs[i] = sampling_radius_mm(lfs[i], options) / options.r;
  }
  const double max_spacing = std::max({grid.spacing.x, grid.spacing.y, grid.spacing.z});
  const PointGrid points(pos, 4.0 * max_spacing);  // the boundary voxels, for the r-cover
  const double r2 = options.r * options.r;

  // Priority = −(h² − r² lfs²): the log of the energy times 2σ², so no exp() underflows.
  std::vector<double> h(lfs), key(n);
  std::vector<char> in_f(n, 1);
  for (std::size_t i = 0; i < n; ++i) key[i] = -(1.0 - r2) * lfs[i] * lfs[i];
  ItemHeap heap(key);  // the points still in F
  SurfaceSamples out;
  out.surface_lfs_max_mm = options.surface_lfs_max_mm;
  while (!heap.empty()) {
    const std::int32_t p = heap.top();
    heap.remove(p);
    in_f[std::size_t(p)] = 0;
    out.voxels.push_back(F[std::size_t(p)]);
    out.priority_mm2.push_back(float(key[std::size_t(p)]));
    const double lfs_p2 = lfs[p] * lfs[p];
    points.for_each_within(pos[p], lfs[p], [&](int q, double d2) {
      if (!in_f[q]) return;
      const double d = std::sqrt(d2);
      h[q] = std::min(h[q], d);
      key[q] = -(h[q] * h[q] - r2 * lfs_p2);
      if (d < options.r * lfs[q]) {
        in_f[q] = 0;
        heap.remove(q);
      } else {
        heap.changed(q);
      }
    });
    if ((out.voxels.size() & 1023) == 0)
      progress("surface sampling", 1.0 - double(heap.size()) / double(n));
  }

  // Projections are independent: in parallel, each into its own slot.
  const std::size_t m = out.voxels.size();
  out.voxel_world.resize(m);
  out.world.resize(m);
  std::vector<char> failed(m, 0);
  tbb::parallel_for(std::size_t(0), m, [&](std::size_t s) {
    const auto c = grid.ijk(std::size_t(out.voxels[s]));
    Vec3 index{double(c[0]), double(c[1]), double(c[2])};
    out.voxel_world[s] = grid.index_to_world(index);
    if (options.project_to_surface &&
        !project_to_level_set(pre.indicator, 0.5f, index, options.max_projection_voxels))
      failed[s] = 1;
    out.world[s] = grid.index_to_world(index);
  });
  out.projection_failures = std::size_t(std::count(failed.begin(), failed.end(), 1));
  return out;
}

}  // namespace cvt
