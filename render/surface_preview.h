// The object's surface as the 3D view shows it before a mesh exists: marching cubes of the
// object mask, coarsened so a software rasteriser (Mesa llvmpipe) draws it in a few
// milliseconds, and Taubin-smoothed so the voxel staircase does not hide the shape. GL-free.
#pragma once

#include <cstddef>

#include "fields/marching_cubes.h"
#include "base/volume.h"

namespace cvt::render {

// `object` itself, or a block-majority downsampling by an integer factor (same world extent)
// when its boundary would give more than about max_triangles marching-cubes triangles.
Mask display_mask(const Mask& object, std::size_t boundary_voxels, std::size_t max_triangles);

// Taubin λ|μ smoothing (shrink-free Laplacian) of the vertices, `iterations` pairs of passes.
void smooth_surface(TriangleSurface& surface, int iterations);

// display_mask → marching_cubes → smooth_surface.
TriangleSurface object_surface_preview(const Mask& object, std::size_t boundary_voxels,
                                       std::size_t max_triangles = 60000);

}  // namespace cvt::render
