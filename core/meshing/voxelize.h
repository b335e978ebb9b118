// Which voxel centres a tet mesh covers: the mesh side of fidelity refinement's comparison
// with the segmentation.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "base/progress.h"
#include "base/tet_mesh.h"
#include "base/volume.h"

namespace cvt {

// Voxels of `grid` whose centre lies in a tet of `mesh` (closed tets, world coordinates).
Mask voxelize(const TetMesh& mesh, const Grid& grid, const Progress& progress = {});

// voxelize() of a mesh that changes a little at a time (fidelity refinement's rounds change it
// only around their new samples): each update voxelizes again only the blocks of voxels that
// tets added or removed since the last update reach, with the same result as voxelize().
// Between updates it keeps the voxels as runs, a small fraction of the mask.
class IncrementalVoxelizer {
 public:
  explicit IncrementalVoxelizer(const Grid& grid);

  // vertex_id[v] names mesh vertex v's point across updates: the same point keeps its id.
  Mask update(const TetMesh& mesh, const std::vector<std::int32_t>& vertex_id,
              const Progress& progress = {});

 private:
  struct Run {
    std::size_t start;  // linear voxel index
    std::int32_t length;
  };

  Grid grid_;
  bool empty_ = true;                              // no update yet
  std::vector<Run> inside_;                        // the last mesh's voxels, in index order
  std::vector<std::array<std::int32_t, 4>> tets_;  // the last mesh: corner ids, each sorted
  std::vector<Vec3> corner_;                       // by id: the point in index space
};

}  // namespace cvt
