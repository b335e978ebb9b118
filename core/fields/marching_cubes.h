// Meshes made straight from a binary mask, in world coordinates (mm): its marching-cubes surface
// (the reference boundary for geometric fidelity) and its voxels split into tets (a baseline
// mesh and a test generator).
#pragma once

#include <vector>

#include "base/tet_mesh.h"
#include "base/volume.h"

namespace cvt {

// A triangle surface; triangles are oriented with normals pointing out of the object.
struct TriangleSurface {
  std::vector<Vec3> vertices;       // world (mm)
  std::vector<Triangle> triangles;  // indices into vertices
};

// The 0.5 iso-surface of the mask (non-zero = inside; treated as 0 outside the grid, so it is
// closed) by marching cubes over the cubes whose corners are voxel centres: the surface of ITK's
// itk::BinaryMask3DMeshSource on the box of the object padded by one voxel, made from a table of
// ITK's triangles for each of the 256 cube cases (ITK run once per case), cube layers in
// parallel. Vertices sit at the midpoints of in/out voxel-centre edges (and at some cube and
// face centres, where ITK puts them), numbered in (z, y, x) order; triangles come cube by cube
// in (z, y, x) order; ambiguous
// faces keep the inside corners apart (the surface of the 6-connected object), so the result is
// a closed, outward-oriented 2-manifold; world (mm). Masks up to 2^20 voxels along each axis.
TriangleSurface marching_cubes(const Mask& mask);

// The Euler characteristic (V − E + F) of marching_cubes(mask), counted cube by cube from its
// cases without making the surface (a ball 2, a torus 0, a ball with a cavity 4).
long long marching_cubes_euler(const Mask& mask);

// Every non-zero voxel as a cube (corners at voxel centre ± spacing/2, world) split into six
// positively oriented tets around its main diagonal (Kuhn split; conforming between
// neighbouring voxels). Its boundary is the staircase voxel surface; it is a 2-manifold unless
// voxels touch only along an edge or at a corner.
TetMesh voxel_tet_mesh(const Mask& mask);

}  // namespace cvt
