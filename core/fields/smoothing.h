// The smoothed indicator: a Gaussian of the binary object whose 0.5 level set is a sub-voxel
// boundary surface (no staircase) that surface samples can be projected onto.
#pragma once

#include "base/progress.h"
#include "base/volume.h"

namespace cvt {

// Gaussian of `mask` (values 0/1) with standard deviation sigma_mm (physical, isotropic),
// truncated at 3σ, separable. sigma_mm ≤ 0 returns the mask as 0/1 floats. Checks progress for
// a cancel every plane of lines.
Volume<float> smooth_indicator(const Mask& mask, double sigma_mm, const Progress& progress = {});

// Trilinear value of `field` at a continuous index (clamped to the grid); of a mask, of its
// values as 0/1 (whose 0.5 level is the surface marching cubes draws).
float sample_trilinear(const Volume<float>& field, const Vec3& index);
float sample_trilinear(const Mask& mask, const Vec3& index);
// Gradient (per mm, in the grid's local axis frame) by central differences of trilinear values.
Vec3 gradient_local(const Volume<float>& field, const Vec3& index);
Vec3 gradient_local(const Mask& mask, const Vec3& index);

}  // namespace cvt
