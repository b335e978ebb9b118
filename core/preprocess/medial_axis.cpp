#include "preprocess/medial_axis.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>

#include <tbb/parallel_for.h>

namespace cvt {

double effective_min_separation_mm(const MedialAxisOptions& options, double sizing_unit_mm) {
  return options.min_separation_mm > 0 ? options.min_separation_mm : 3.0 * sizing_unit_mm;
}

Mask compute_medial_axis(const Mask& object, const Volume<std::int32_t>& nearest_opposite,
                         const MedialAxisOptions& options, const Progress& progress) {
  const Grid& g = object.grid;
  Mask axis(g, 0);
  const double lambda = options.min_separation_mm;
  const double lambda2 = lambda * lambda;
  const double cos_max = std::cos(options.min_angle_deg * std::numbers::pi / 180.0);
  const std::ptrdiff_t steps[3] = {1, g.dims[0], std::ptrdiff_t(g.dims[0]) * g.dims[1]};

  // A feature's position from its linear index; 32-bit division (indices are int32), as this
  // runs for most pairs of neighbours.
  const std::uint32_t nx = std::uint32_t(g.dims[0]), ny = std::uint32_t(g.dims[1]);
  auto local = [&](std::int32_t v) {
    const std::uint32_t u = std::uint32_t(v), row = u / nx;
    return Vec3{double(u - row * nx) * g.spacing.x, double(row % ny) * g.spacing.y,
                double(row / ny) * g.spacing.z};
  };
  // Pairs (p, p + e_axis) are tested once each; a voxel may be marked from several pairs, so
  // marks are relaxed atomic stores of the same value.
  tbb::parallel_for(0, g.dims[2], [&](int k) {
    progress.check_cancelled();
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i) {
        const std::size_t p = g.linear(i, j, k);
        const std::int32_t a_idx = nearest_opposite.data[p];
        if (a_idx < 0) continue;
        const int coord[3] = {i, j, k};
        const Vec3 xp = g.index_to_local({double(i), double(j), double(k)});
        std::optional<Vec3> a_at;  // a's position, once a pair needs it
        for (int ax = 0; ax < 3; ++ax) {
          if (coord[ax] + 1 >= g.dims[ax]) continue;
          const std::size_t q = p + steps[ax];
          if (object.data[q] != object.data[p]) continue;
          const std::int32_t b_idx = nearest_opposite.data[q];
          if (b_idx < 0 || b_idx == a_idx) continue;
          if (!a_at) a_at = local(a_idx);
          const Vec3 a = *a_at, b = local(b_idx);
          if (squared_distance(a, b) < lambda2) continue;
          int cq[3] = {i, j, k};
          ++cq[ax];
          const Vec3 xq = g.index_to_local({double(cq[0]), double(cq[1]), double(cq[2])});
          const Vec3 u = a - xp, w = b - xq;
          if (dot(u, w) > cos_max * norm(u) * norm(w)) continue;
          // Mark whichever of p, q is nearer the bisector plane of a and b.
          const double gp = std::abs(squared_distance(xp, a) - squared_distance(xp, b));
          const double gq = std::abs(squared_distance(xq, a) - squared_distance(xq, b));
          const std::size_t mark = gp <= gq ? p : q;
          std::atomic_ref<unsigned char>(axis.data[mark])
              .store(object.data[p] ? 1 : 2, std::memory_order_relaxed);
        }
      }
  });
  return axis;
}

}  // namespace cvt
