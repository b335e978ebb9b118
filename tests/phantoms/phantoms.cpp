#include "phantoms.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

namespace cvt {

Phantom sphere_phantom(const Vec3& c, double r) {
  return {"sphere", [=](const Vec3& p) { return distance(p, c) - r; }, c, r};
}

Phantom torus_phantom(const Vec3& c, double major, double minor) {
  auto sd = [=](const Vec3& p) {
    const Vec3 q = p - c;
    const double ring = std::hypot(q.x, q.y) - major;
    return std::hypot(ring, q.z) - minor;
  };
  return {"torus", sd, c, major + minor};
}

Phantom slab_phantom(const Vec3& c, double thickness, double half_width) {
  auto sd = [=](const Vec3& p) {
    const Vec3 q = p - c;
    const double dx = std::abs(q.x) - half_width, dy = std::abs(q.y) - half_width,
                 dz = std::abs(q.z) - 0.5 * thickness;
    const double outside = std::sqrt(std::pow(std::max(dx, 0.0), 2) +
                                     std::pow(std::max(dy, 0.0), 2) +
                                     std::pow(std::max(dz, 0.0), 2));
    return outside + std::min(std::max({dx, dy, dz}), 0.0);
  };
  return {"slab", sd, c, std::sqrt(2 * half_width * half_width + 0.25 * thickness * thickness)};
}

Phantom hollow_sphere_phantom(const Vec3& c, double inner, double outer) {
  auto sd = [=](const Vec3& p) {
    const double d = distance(p, c);
    return std::max(d - outer, inner - d);
  };
  return {"hollow_sphere", sd, c, outer};
}

Phantom two_spheres_phantom(const Vec3& c, double r, double gap) {
  const Vec3 offset{r + 0.5 * gap, 0, 0};
  const Vec3 a = c - offset, b = c + offset;
  auto sd = [=](const Vec3& p) { return std::min(distance(p, a), distance(p, b)) - r; };
  return {"two_spheres", sd, c, 2 * r + 0.5 * gap};
}

Grid grid_around(const Phantom& phantom, const Vec3& spacing,
                 const std::array<double, 9>& direction, int margin_voxels) {
  Grid g;
  g.spacing = spacing;
  g.direction = direction;
  for (int a = 0; a < 3; ++a)
    g.dims[a] = 2 * (int(std::ceil(phantom.radius / spacing[a])) + margin_voxels) + 1;
  // Put the grid's centre voxel on the phantom's centre.
  g.origin = {0, 0, 0};
  const Vec3 centre_offset =
      g.index_to_world({0.5 * (g.dims[0] - 1), 0.5 * (g.dims[1] - 1), 0.5 * (g.dims[2] - 1)});
  g.origin = phantom.center - centre_offset;
  return g;
}

Image rasterize(const Phantom& phantom, const Grid& grid) {
  Image image;
  image.voxels = Volume<float>(grid, 0.0f);
  image.integer_valued = true;
  image.pixel_type = "uint8";
  image.source = phantom.name;
  tbb::parallel_for(0, grid.dims[2], [&](int k) {
    for (int j = 0; j < grid.dims[1]; ++j)
      for (int i = 0; i < grid.dims[0]; ++i)
        if (phantom.signed_distance(grid.index_to_world({double(i), double(j), double(k)})) < 0)
          image.voxels.at(i, j, k) = 1.0f;
  });
  return image;
}

std::array<double, 9> rotation_matrix(const Vec3& axis_in, double angle) {
  const Vec3 u = axis_in / norm(axis_in);
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  return {t * u.x * u.x + c,       t * u.x * u.y - s * u.z, t * u.x * u.z + s * u.y,
          t * u.x * u.y + s * u.z, t * u.y * u.y + c,       t * u.y * u.z - s * u.x,
          t * u.x * u.z - s * u.y, t * u.y * u.z + s * u.x, t * u.z * u.z + c};
}

}  // namespace cvt
