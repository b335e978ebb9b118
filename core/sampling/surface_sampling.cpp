#include "sampling/surface_sampling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <queue>

#include "base/errors.h"
#include "base/point_grid.h"
#include "fields/smoothing.h"

namespace cvt {
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
                                double r) {
  double s2 = 0, s3 = 0;
  for (std::int32_t v : samples.voxels) {
    const double s = r * lfs_mm.data[v];
    s2 += s * s;
    s3 += s * s * s;
  }
  return s2 > 0 ? s3 / s2 : 0.0;
}

SurfaceSamples sample_surface(const PreprocessResult& pre, const SurfaceSamplingOptions& options,
                              const Progress& progress) {
  if (!(options.r > 0 && options.r < 1)) throw InputError("--r: must be in (0, 1)");
  const Grid& grid = pre.object.grid;
  const std::vector<std::int32_t>& F = pre.boundary;
  const std::size_t n = F.size();
  std::vector<Vec3> pos(n);
  std::vector<double> lfs(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = grid.ijk(std::size_t(F[i]));
    pos[i] = grid.index_to_local({double(c[0]), double(c[1]), double(c[2])});
    lfs[i] = pre.lfs_mm.data[F[i]];
  }
  const double max_spacing = std::max({grid.spacing.x, grid.spacing.y, grid.spacing.z});
  const PointGrid points(pos, 4.0 * max_spacing);  // the boundary voxels, for the r-cover
  const double r2 = options.r * options.r;

  // Priority = −(h² − r² lfs²): the log of the energy times 2σ², so no exp() underflows.
  std::vector<double> h(lfs), key(n);
  std::vector<char> in_f(n, 1);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry> queue;
  for (std::size_t i = 0; i < n; ++i) {
    key[i] = -(1.0 - r2) * lfs[i] * lfs[i];
    queue.push({key[i], int(i)});
  }
  SurfaceSamples out;
  std::size_t remaining = n;
  while (!queue.empty()) {
    const auto [k, p] = queue.top();
    queue.pop();
    if (!in_f[p] || k != key[p]) continue;  // stale entry
    in_f[p] = 0;
    --remaining;
    out.voxels.push_back(F[p]);
    out.priority_mm2.push_back(float(k));
    const double lfs_p2 = lfs[p] * lfs[p];
    points.for_each_within(pos[p], lfs[p], [&](int q, double d2) {
      if (!in_f[q]) return;
      const double d = std::sqrt(d2);
      h[q] = std::min(h[q], d);
      key[q] = -(h[q] * h[q] - r2 * lfs_p2);
      if (d < options.r * lfs[q]) {
        in_f[q] = 0;
        --remaining;
      } else {
        queue.push({key[q], q});
      }
    });
    if ((out.voxels.size() & 1023) == 0)
      progress("surface sampling", 1.0 - double(remaining) / double(n));
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
