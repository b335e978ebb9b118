#include "base/grid.h"

#include <cmath>

namespace cvt {

Vec3 Grid::index_to_world(const Vec3& index) const {
  const Vec3 s = index_to_local(index);
  const auto& d = direction;
  return {origin.x + d[0] * s.x + d[1] * s.y + d[2] * s.z,
          origin.y + d[3] * s.x + d[4] * s.y + d[5] * s.z,
          origin.z + d[6] * s.x + d[7] * s.y + d[8] * s.z};
}

Vec3 Grid::world_to_index(const Vec3& world) const {
  // direction is orthonormal, so its inverse is its transpose.
  const Vec3 r = world - origin;
  const auto& d = direction;
  return {(d[0] * r.x + d[3] * r.y + d[6] * r.z) / spacing.x,
          (d[1] * r.x + d[4] * r.y + d[7] * r.z) / spacing.y,
          (d[2] * r.x + d[5] * r.y + d[8] * r.z) / spacing.z};
}

Grid Grid::sub_grid(const std::array<int, 3>& offset, const std::array<int, 3>& new_dims) const {
  Grid g = *this;
  g.dims = new_dims;
  g.origin = index_to_world({double(offset[0]), double(offset[1]), double(offset[2])});
  return g;
}

bool Grid::same_geometry(const Grid& o, double tol) const {
  if (dims != o.dims) return false;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(spacing[a] - o.spacing[a]) > tol) return false;
    if (std::abs(origin[a] - o.origin[a]) > tol) return false;
  }
  for (int a = 0; a < 9; ++a)
    if (std::abs(direction[a] - o.direction[a]) > tol) return false;
  return true;
}

}  // namespace cvt
