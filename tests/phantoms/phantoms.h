// Analytic test objects, given by their signed distance (mm, negative inside), rasterised into
// label images (1 inside, 0 outside) on any grid. Used by the tests and to make assets/.
#pragma once

#include <functional>
#include <string>

#include "base/image.h"

namespace cvt {

struct Phantom {
  std::string name;
  std::function<double(const Vec3& world)> signed_distance;  // mm; < 0 inside
  Vec3 center;                                                // world (mm)
  double radius = 0;                                          // bounding radius (mm)
};

Phantom sphere_phantom(const Vec3& center, double radius_mm);
// Torus around the world z axis through `center`.
Phantom torus_phantom(const Vec3& center, double major_mm, double minor_mm);
// Box of thickness t along world z and half-width `half_width_mm` along x and y.
Phantom slab_phantom(const Vec3& center, double thickness_mm, double half_width_mm);
Phantom hollow_sphere_phantom(const Vec3& center, double inner_mm, double outer_mm);
// Two spheres of radius r whose centres are `gap_mm` + 2r apart along x (gap 0: touching).
Phantom two_spheres_phantom(const Vec3& center, double radius_mm, double gap_mm);

// A grid with the given spacing and direction whose voxels cover the phantom's bounding ball
// plus `margin_voxels`, centred on it.
Grid grid_around(const Phantom& phantom, const Vec3& spacing_mm,
                 const std::array<double, 9>& direction, int margin_voxels = 3);

// Label image: 1 where the signed distance at the voxel centre is < 0. pixel_type "uint8".
Image rasterize(const Phantom& phantom, const Grid& grid);

// A rotation matrix (row-major) about `axis` (normalised inside) by `angle_rad`.
std::array<double, 9> rotation_matrix(const Vec3& axis, double angle_rad);

}  // namespace cvt
