#include "preprocess/object_scale.h"

#include <algorithm>
#include <tbb/blocked_range.h>

#include <tbb/parallel_reduce.h>

namespace cvt {

double volume_to_area_mm(const Mask& object) {
  const Grid& g = object.grid;
  const double face[3] = {g.spacing.y * g.spacing.z, g.spacing.x * g.spacing.z,
                          g.spacing.x * g.spacing.y};
  // Integer counts, so the sum is the same whatever the order of the parallel reduction.
  struct Sums {
    long long voxels = 0, faces[3] = {0, 0, 0};
  };
  const Sums s = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, g.dims[2]), Sums{},
      [&](const tbb::blocked_range<int>& ks, Sums acc) {
        for (int k = ks.begin(); k != ks.end(); ++k)
          for (int j = 0; j < g.dims[1]; ++j)
            for (int i = 0; i < g.dims[0]; ++i) {
              if (!object.at(i, j, k)) continue;
              acc.voxels += 1;
              const int c[3] = {i, j, k};
              for (int a = 0; a < 3; ++a)
                for (int step : {-1, 1}) {
                  int n[3] = {c[0], c[1], c[2]};
                  n[a] += step;
                  if (n[a] < 0 || n[a] >= g.dims[a] || !object.at(n[0], n[1], n[2]))
                    ++acc.faces[a];
                }
            }
        return acc;
      },
      [](Sums a, const Sums& b) {
        a.voxels += b.voxels;
        for (int i = 0; i < 3; ++i) a.faces[i] += b.faces[i];
        return a;
      });
  const double area = double(s.faces[0]) * face[0] + double(s.faces[1]) * face[1] +
                      double(s.faces[2]) * face[2];
  if (area <= 0) return 0;
  return double(s.voxels) * g.spacing.x * g.spacing.y * g.spacing.z / area;
}

double sizing_unit_mm(const Mask& object, double volume_to_area) {
  const Vec3& h = object.grid.spacing;
  return std::max({h.x, h.y, h.z, volume_to_area / 9.0});
}

}  // namespace cvt
