// Stage 5, refined for fidelity: where the CRUST-like mesh and the segmentation disagree by
// more than a tolerance (a thin channel the mesh bridges, a thin sheet it misses, a pit carved
// into it), the surface there was sampled too coarsely for the poles to decide. We add surface
// samples on the object's sub-voxel boundary next to those places, drop interior samples that
// crowd them, and triangulate again — a few rounds at most.
#pragma once

#include <cstddef>
#include <vector>

#include "meshing/mesh_generation.h"
#include "meshing/voxelize.h"
#include "preprocess/preprocess.h"

namespace cvt {

// One check of fidelity refinement and the round made from it, if any.
struct FidelityRefinementRound {
  std::size_t disagreeing_voxels = 0;  // voxels where mesh and object differ beyond tolerance
  std::size_t deep_boundary_samples = 0;  // interior samples on the boundary, deep in the object
  std::size_t added_samples = 0;       // surface samples added on the object boundary
  std::size_t dropped_interior = 0;    // interior samples removed: next to the new ones, or
                                       // deep on the boundary
  long long boundary_euler = 0;  // Euler characteristic of the boundary of the mesh checked
  bool accepted = false;  // its round's mesh had fewer deep samples, or as many and fewer
                          // disagreeing voxels; false: dropped, or no round made (the last
                          // check, when nothing was left to fix or no round was left)
  bool returned = false;  // this check's mesh is the result: of the kept meshes, the one
                          // whose boundary Euler characteristic is nearest the object's, then
                          // with the fewest deep samples, then disagreeing voxels
};

// Stage 5's mesh after refinement, with the record of what refinement did. vertex_source is
// into the refined sets: B then added_surface_samples; I without the dropped ones.
struct RefinedMesh : MeshGenerationResult {
  std::vector<Vec3> added_surface_samples;     // world, mm
  std::vector<Vec3> dropped_interior_samples;  // world, mm
  std::vector<FidelityRefinementRound> refinement;  // one per check of a kept mesh; the
                                                    // returned one is marked
};

struct FidelityRefinementOptions {
  int max_rounds = 3;           // re-triangulations at most; 0 = plain stage 5
  double tolerance_mm = 0;      // allowed disagreement; 0 = auto (1.5 × largest voxel spacing)
  double sample_spacing_mm = 0; // new samples keep this far from each other and from B;
                                // 0 = auto (r × lfs-min, at least ½ smallest voxel spacing)
  double r = 0.4;               // the r-sampling ratio, for the auto spacing above
};

// The occupancy of stage 5: the smoothed indicator, trilinear, 0 outside its grid.
OccupancyFunction indicator_occupancy(const Volume<float>& indicator);

struct FidelityFix {
  std::size_t disagreeing_voxels = 0;  // where mesh and object differ by more than the tolerance
  // Of the interior samples on the mesh boundary, those deeper in the object than the tolerance
  // (indices into exposed_interior): the bottoms of pits too narrow to hold a voxel centre
  // (presumably an exterior pole reached the sample through a gap in the surface samples).
  std::vector<std::size_t> deep_boundary;
  std::vector<Vec3> samples;           // surface samples to add (world, mm), spaced by at least
                                       // the spacing from each other and the existing ones
  std::vector<Vec3> outside_points;    // centres of those voxels the mesh covers though they are
                                       // outside the smoothed object (world, mm)
};

// Where `mesh_inside` and pre.object disagree by more than the tolerance, and what to do there.
// `exposed_interior`: the interior samples that lie on the mesh boundary (world, mm); each one
// deeper in the object than the tolerance gets a new surface sample where the object boundary
// is nearest to it.
FidelityFix find_fidelity_fix(const Mask& mesh_inside, const PreprocessResult& pre,
                              const std::vector<Vec3>& existing, double tolerance_mm,
                              double spacing_mm, const Progress& progress = {},
                              const std::vector<Vec3>& exposed_interior = {});

// The interior samples among the boundary vertices of a stage-5 mesh, as indices into its I
// (vertex_source − surface_count), in vertex order.
std::vector<int> interior_samples_on_boundary(const MeshGenerationResult& m,
                                              std::size_t surface_count);

// Stage 5 with up to max_rounds of refinement; the result records what was added and dropped.
// A small_tet_edge_mm of 0 becomes 2 × the largest voxel spacing here.
RefinedMesh build_refined_mesh(const PreprocessResult& pre, const std::vector<Vec3>& surface,
                               const std::vector<Vec3>& interior,
                               const MeshGenerationOptions& generation,
                               const FidelityRefinementOptions& options,
                               const Progress& progress = {});

}  // namespace cvt
