// Stage 7: geometric fidelity of a mesh to the segmentation it came from — volume error and
// distances between the mesh boundary and the object's marching-cubes surface.
#pragma once

#include <cstddef>
#include <nlohmann/json_fwd.hpp>

#include "base/image.h"
#include "base/progress.h"
#include "base/tet_mesh.h"
#include "base/volume.h"
#include "fields/marching_cubes.h"
#include "preprocess/cleanup.h"
#include "preprocess/object_selection.h"

namespace cvt {

// Symmetric distance between two surfaces A and B, sampled at spacing h (distance_samples.h):
// every triangle is cut into k² pieces with edges ≤ h, the pieces are grouped by the cube of side
// h that holds their centroid, and each group is one sample, at the centroid of one of its
// pieces drawn with probability ∝ area, standing for the group's area (about one sample per h²
// of surface, however small the triangles; deterministic). Each sample's distance is the exact distance to the nearest triangle of the other
// surface (a grid of triangle buckets, triangle_grid.h). Means and the percentile weight samples
// by the area they stand for. The maxima are refined where the distance, being 1-Lipschitz,
// allows a value larger than the largest sample: the 1024 groups with the largest bound are
// measured piece by piece, then the 256 pieces with the largest bound are split further (their
// corners sampled too), to max_error_mm or 1/16 of the spacing.
struct SurfaceDistance {
  double hausdorff_mm = 0;  // max(a_to_b_max_mm, b_to_a_max_mm)
  double mean_mm = 0;       // area-weighted mean over both directions (ASSD)
  double p95_mm = 0;        // area-weighted 95th percentile over both directions
  double a_to_b_max_mm = 0, a_to_b_mean_mm = 0;
  double b_to_a_max_mm = 0, b_to_a_mean_mm = 0;
  Vec3 a_to_b_max_at, b_to_a_max_at;  // where the maxima are: a sample of a, of b (mm)
  double sample_spacing_mm = 0;  // the spacing used (may be coarser than asked, see max_samples)
  std::size_t samples_a = 0, samples_b = 0;
};

struct SurfaceDistanceOptions {
  double sample_spacing_mm = 0;       // ≤ 0: 1/200 of the larger bounding-box diagonal
  std::size_t max_samples = 4000000;  // samples per surface; the spacing grows to stay below
  double max_error_mm = 0;            // of the maxima; ≤ 0: 2 % of the sample spacing
};

// Checks progress for a cancel between steps and every thousand or so samples (throws Cancelled).
SurfaceDistance surface_distance(const TriangleSurface& a, const TriangleSurface& b,
                                 const SurfaceDistanceOptions& options = {},
                                 const Progress& progress = {});
// Between the boundary surfaces of two tet meshes.
SurfaceDistance surface_distance(const TetMesh& a, const TetMesh& b,
                                 const SurfaceDistanceOptions& options = {});

// The boundary of a tet mesh as a surface (all mesh vertices kept; unused ones are ignored).
TriangleSurface boundary_surface(const TetMesh& mesh);

struct FidelityOptions {
  // Sample spacing in smallest voxel spacings: two keep the liver's mean and 95th percentile
  // within 0.003 mm of a spacing of half a voxel, with a fifteenth of the samples.
  double sample_spacing_voxels = 2.0;
  std::size_t max_samples = 4000000;  // samples per surface (see SurfaceDistanceOptions)
};

struct FidelityReport {
  double mesh_volume_mm3 = 0;       // Σ signed tet volumes
  double object_volume_mm3 = 0;     // object voxel count × voxel volume
  double volume_error_percent = 0;  // 100 (mesh − object) / object (signed)
  std::size_t object_surface_triangles = 0;
  long long object_surface_euler = 0;         // of the marching-cubes surface, to hold the mesh
  std::size_t object_surface_components = 0;  // boundary's topology against

  SurfaceDistance distance;  // A = mesh boundary, B = object's marching-cubes surface
};

// Fidelity of `mesh` (world, mm) to `object` (non-zero voxels; world positions from its grid).
// Takes a fraction of a second to seconds on a big object, so it checks progress for a cancel as
// surface_distance does.
FidelityReport compute_fidelity(const TetMesh& mesh, const Mask& object,
                                const FidelityOptions& options = {}, const Progress& progress = {});

// The object a mesh of `image` is judged against: the selection after stage 1's clean-up
// (cavities filled, specks dropped), exactly as the pipeline builds it, so `cvtmesh quality
// --image` and a run report agree. Judging against the raw selection would count enclosed
// background voxels, which every mesher fills, as missed boundary. Throws InputError naming the
// image when nothing is left.
Mask fidelity_object(const Image& image, const ObjectSelection& selection,
                     const CleanupOptions& cleanup);

// {"mesh_volume_mm3","object_volume_mm3","volume_error_percent","hausdorff_mm","mean_mm",
//  "p95_mm","mesh_to_object":{"max_mm","max_at_mm":[x,y,z],"mean_mm"},"object_to_mesh":{...},
//  "sample_spacing_mm",
//  "samples":{"mesh","object"},"object_surface_triangles","object_surface_euler",
//  "object_surface_components"}
nlohmann::json to_json(const FidelityReport& report);

}  // namespace cvt
