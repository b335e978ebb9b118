// Stage 4 (paper III-E): shallow-point elimination. An interior site whose discrete Voronoi
// region contains a boundary voxel of F sits too close to the surface (its Voronoi facets would
// not be nearly perpendicular to the surface, which makes holes in the mesh), so it is removed.
#pragma once

#include <cstdint>
#include <vector>

#include "base/grid.h"

namespace cvt {

struct ShallowResult {
  std::vector<Vec3> kept_world;          // interior samples I without the shallow ones (mm)
  std::vector<Vec3> removed_world;       // the shallow ones, for the viewer (drawn red)
  std::vector<std::int32_t> kept_index;  // their indices in the input sites
  std::vector<std::int32_t> removed_index;
};

// boundary_owners[f]: the site owning boundary voxel f (any order, −1 ignored), e.g. from
// LloydStepper::owners_of(pre.boundary). Sites keep their input order in both lists.
ShallowResult remove_shallow_points(const std::vector<Vec3>& sites_world,
                                    const std::vector<std::int32_t>& boundary_owners);

// Same, computing the owners of the boundary voxels F (linear indices into `grid`) by exact
// nearest-site search; only F's owners are needed, never a full label volume.
ShallowResult remove_shallow_points(const Grid& grid, const std::vector<Vec3>& sites_world,
                                    const std::vector<std::int32_t>& boundary);

}  // namespace cvt
