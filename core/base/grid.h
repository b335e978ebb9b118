// The geometry of a voxel grid in physical space (ITK convention):
//   world = origin + direction · (spacing ⊙ index)
// All lengths are in mm; direction is an orthonormal 3×3 matrix stored row-major.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "base/vec3.h"

namespace cvt {

struct Grid {
  std::array<int, 3> dims{0, 0, 0};                    // voxels along i, j, k
  Vec3 spacing{1, 1, 1};                               // mm between voxel centres along i, j, k
  Vec3 origin{0, 0, 0};                                // world position (mm) of voxel (0,0,0)
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major, columns = axes

  std::size_t voxel_count() const {
    return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
  }
  // Linear index of voxel (i,j,k); i varies fastest.
  std::size_t linear(int i, int j, int k) const {
    return (std::size_t(k) * std::size_t(dims[1]) + std::size_t(j)) * std::size_t(dims[0]) +
           std::size_t(i);
  }
  std::array<int, 3> ijk(std::size_t linear_index) const {
    const std::size_t nx = std::size_t(dims[0]), ny = std::size_t(dims[1]);
    return {int(linear_index % nx), int((linear_index / nx) % ny), int(linear_index / (nx * ny))};
  }
  bool contains(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < dims[0] && j < dims[1] && k < dims[2];
  }

  // Continuous (sub-voxel) index → world (mm).
  Vec3 index_to_world(const Vec3& index) const;
  // World (mm) → continuous index.
  Vec3 world_to_index(const Vec3& world) const;
  Vec3 voxel_to_world(std::size_t linear_index) const {
    auto v = ijk(linear_index);
    return index_to_world({double(v[0]), double(v[1]), double(v[2])});
  }
  // Position in the grid's own axis-aligned frame (mm), without origin and rotation:
  // spacing ⊙ index. Distances computed here equal world distances.
  Vec3 index_to_local(const Vec3& index) const {
    return {index.x * spacing.x, index.y * spacing.y, index.z * spacing.z};
  }

  // The grid of the sub-block starting at voxel `offset` with `new_dims` voxels (offset may be
  // negative, for padding); same spacing and direction, origin moved so world positions agree.
  Grid sub_grid(const std::array<int, 3>& offset, const std::array<int, 3>& new_dims) const;

  bool same_geometry(const Grid& other, double tolerance = 1e-6) const;
};

}  // namespace cvt
