#include "surface_preview.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace cvt::render {

Mask display_mask(const Mask& object, std::size_t boundary_voxels, std::size_t max_triangles) {
  // Marching cubes makes about 2.5 triangles per boundary voxel; downsampling by f divides
  // the boundary by about f².
  const double estimate = 2.5 * double(boundary_voxels);
  const int f =
      int(std::ceil(std::sqrt(estimate / double(std::max<std::size_t>(max_triangles, 1)))));
  if (f <= 1) return object;
  const Grid& g = object.grid;
  std::array<int, 3> dims;
  for (int a = 0; a < 3; ++a) dims[a] = std::max(1, (g.dims[a] + f - 1) / f);
  Grid coarse = g;
  coarse.dims = dims;
  coarse.spacing = g.spacing * double(f);
  // Coarse voxel centres sit at the centres of their f³ blocks.
  coarse.origin = g.index_to_world({0.5 * (f - 1), 0.5 * (f - 1), 0.5 * (f - 1)});
  Mask out(coarse, 0);
  tbb::parallel_for(0, dims[2], [&](int K) {
    for (int J = 0; J < dims[1]; ++J)
      for (int I = 0; I < dims[0]; ++I) {
        int inside = 0, total = 0;
        for (int k = K * f; k < std::min((K + 1) * f, g.dims[2]); ++k)
          for (int j = J * f; j < std::min((J + 1) * f, g.dims[1]); ++j)
            for (int i = I * f; i < std::min((I + 1) * f, g.dims[0]); ++i)
              inside += object.at(i, j, k) != 0, ++total;
        out.at(I, J, K) = 2 * inside >= total ? 1 : 0;
      }
  });
  return out;
}

void smooth_surface(TriangleSurface& surface, int iterations) {
  const std::size_t n = surface.vertices.size();
  // Vertex neighbours through triangle edges (each edge seen from both triangles: duplicates
  // weight the average slightly, which does not matter for display).
  std::vector<std::vector<std::int32_t>> neighbours(n);
  for (const Triangle& t : surface.triangles)
    for (int k = 0; k < 3; ++k) {
      neighbours[t[k]].push_back(t[(k + 1) % 3]);
      neighbours[t[k]].push_back(t[(k + 2) % 3]);
    }
  std::vector<Vec3> next(n);
  auto pass = [&](double factor) {
    for (std::size_t v = 0; v < n; ++v) {
      if (neighbours[v].empty()) {
        next[v] = surface.vertices[v];
        continue;
      }
      Vec3 mean;
      for (std::int32_t u : neighbours[v]) mean += surface.vertices[u];
      mean = mean / double(neighbours[v].size());
      next[v] = surface.vertices[v] + (mean - surface.vertices[v]) * factor;
    }
    surface.vertices.swap(next);
  };
  for (int i = 0; i < iterations; ++i) {
    pass(0.5);    // λ: smooth
    pass(-0.53);  // μ: inflate back, so the volume does not shrink
  }
}

TriangleSurface object_surface_preview(const Mask& object, std::size_t boundary_voxels,
                                       std::size_t max_triangles) {
  TriangleSurface surface = marching_cubes(display_mask(object, boundary_voxels, max_triangles));
  smooth_surface(surface, 10);
  return surface;
}

}  // namespace cvt::render
