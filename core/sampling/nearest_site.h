// The exactly nearest site of voxels: sites bucketed in a PointGrid, the sites that can be
// nearest somewhere in a box of voxels as candidates, then the nearest candidate per voxel with
// one expression on every code path, so ties (to the first candidate, in grid order) resolve
// alike everywhere. The Lloyd loop (cvt_sampling.h) takes a brick at a time through vector code;
// the owners of arbitrary voxels (stage 4, the viewer's slices) come from the scalar loop.
//
// Sites and voxel positions are in the grid's local frame (mm, spacing ⊙ index, no origin or
// rotation).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/grid.h"
#include "base/point_grid.h"
#include "base/vec3.h"

namespace cvt {

// Voxels per brick along i = one kernel row: two AVX2 vectors of 4 doubles, two independent
// compare/blend chains per candidate.
inline constexpr int kBrickRow = 8;

// The sites bucketed for the queries below: cells of cell_mm over the voxel centres of `grid`
// (sites jittered outside fall into the border cells); 0 = about one site per cell.
PointGrid site_grid(const Grid& grid, const std::vector<Vec3>& sites_local, double cell_mm);

// The sites that may be nearest to some point of a box, structure of arrays for the kernels.
// The arrays only grow (reused brick after brick); size() entries are valid.
struct Candidates {
  static constexpr int kPad = 8;  // entries kept past size(): the kernels read whole vectors
  std::vector<std::int32_t> id;   // index of the site
  std::vector<double> x, y, z;    // its position (mm)
  int n = 0;
  int size() const { return n; }
  void ensure(std::size_t k) {
    if (k + kPad <= x.size()) return;
    k = std::max(k, 2 * x.size()) + kPad;
    id.resize(k), x.resize(k), y.resize(k), z.resize(k);
  }
};

// A brick of voxels: kBrickRow voxels along i, rows along j, then layers along k.
struct VoxelBrick {
  std::array<int, 3> origin;  // first voxel
  std::array<int, 3> lo, hi;  // bounding box of its object voxels (voxel indices, inclusive)
};

// What nearest_in_brick finds, and its working memory; one per thread, reused brick after brick.
struct BrickNearest {
  Candidates cand;
  std::vector<std::int32_t> owner;  // per brick slot: index into cand
  std::vector<double> d2;           // per brick slot: squared distance to that owner (mm²)
  std::vector<double> c_yz;         // per candidate: (y − zy)² + (z − zz)² of the current row
  std::vector<int> keep;            // the candidates that may be nearest in the current row
};

// The nearest site of every slot of a brick of `dims` voxels (dims[0] == kBrickRow), slots in
// row order; `weight` per slot is < 0 outside the object. Rows without object voxels are left
// as they were.
void nearest_in_brick(const Grid& grid, const PointGrid& sites, const VoxelBrick& brick,
                      const std::array<int, 3>& dims, const std::int32_t* weight,
                      BrickNearest& out);

// Owners (index of the nearest site) of the given voxels (linear indices into `grid`); throws
// InputError for an index outside the grid.
std::vector<std::int32_t> nearest_site_owners(const Grid& grid, const PointGrid& sites,
                                              const std::vector<std::int32_t>& voxels);
// The same for sites given in the local frame; all −1 without sites.
std::vector<std::int32_t> nearest_site_owners(const Grid& grid,
                                              const std::vector<Vec3>& sites_local,
                                              const std::vector<std::int32_t>& voxels);

}  // namespace cvt
