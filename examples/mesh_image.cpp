// From a segmented image to a tetrahedral mesh file, calling the stages one by one (what
// `cvtmesh mesh IMAGE -o OUT` does through the Pipeline, with its default parameters).
//   mesh_image IMAGE OUT.(mesh|vtu|msh|inp|feb|node|stl|ply|obj)
#include <cstdio>
#include <exception>

#include "io/image_io.h"
#include "io/mesh_export.h"
#include "meshing/fidelity_refinement.h"
#include "optimize/mesh_optimization.h"
#include "pipeline/pipeline.h"
#include "preprocess/preprocess.h"
#include "sampling/cvt_sampling.h"
#include "sampling/shallow_points.h"
#include "sampling/surface_sampling.h"

using namespace cvt;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s IMAGE OUT.mesh\n", argv[0]);
    return 2;
  }
  try {
    const Image image = read_image(argv[1]);
    // Every stage's options from the default parameters (the registry's defaults).
    const Parameters p;
    // 1. The object (every non-zero label), its smoothed indicator and local feature size.
    const PreprocessResult pre = preprocess(image, preprocess_options(p));
    // 2. Surface samples B: every boundary voxel within r·lfs of one (lfs capped at its median
    //    over the boundary, so flat parts still follow the voxels).
    //    With them, the interior spacing: the samples' spacing r·lfs without the cap, weighted
    //    by the area each one covers.
    const auto [surface, spacing] = sample_surface_and_spacing(pre, surface_options(p, pre));
    // 3. Interior samples I by Lloyd's algorithm, that far apart.
    LloydStepper lloyd(pre, cvt_options(p, spacing));
    lloyd.run_to_convergence();
    // 4. Drop the interior samples whose Voronoi region reaches the boundary.
    const ShallowResult interior =
        remove_shallow_points(lloyd.sites_world(), lloyd.owners_of(pre.boundary));
    // 5. Delaunay of B, I and the exterior poles, outside tets removed, refined where the mesh
    //    departs from the object.
    RefinedMesh result =
        build_refined_mesh(pre, surface.world, interior.kept_world, mesh_options(p),
                           refinement_options(p));
    // 6. Optimisation: flips, vertex moves and insertions remove the slivers.
    optimize_mesh(result.mesh, &pre.indicator, p.optimization, {}, &pre.object);
    write_mesh_with_quality(result.mesh, argv[2]);
    std::printf("%zu surface + %zu interior samples -> %zu vertices, %zu tets -> %s\n",
                surface.world.size(), interior.kept_world.size(), result.mesh.vertices.size(),
                result.mesh.tets.size(), argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mesh_image: %s\n", e.what());
    return 1;
  }
  return 0;
}
