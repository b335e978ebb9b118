// Stage 5 (paper III-F): a CRUST-like Delaunay mesh. Poles of the surface samples B come from
// the Voronoi diagram of B; those outside the object (EP) join B ∪ I in a second Delaunay
// triangulation, and every tet incident to a pole is deleted. Tets that still lie outside the
// object (deep concavities) are removed by a second, documented rule: centroid outside. A third
// rule makes the boundary a closed 2-manifold: a sample where the boundary pinches (two sheets
// touch, or tets meet only along an edge) is deleted from the triangulation and rules 1–2 are
// applied again; whatever still pinches after a few rounds is peeled (manifold_repair.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "meshing/manifold_repair.h"
#include "base/progress.h"
#include "base/tet_mesh.h"

namespace cvt {

// Occupancy of the object at a world point (mm): 1 deep inside, 0 far outside, 0.5 on the
// boundary surface (the smoothed indicator of stage 1).
using OccupancyFunction = std::function<double(const Vec3& world)>;

struct MeshGenerationOptions {
  // Every pole below inside_from is exterior (EP) and carves. Poles hugging the surface (up to
  // 0.5) can carve tets deep inside the object, so those at or above this ("slit poles": in a
  // slit narrower than the smoothing the indicator never drops below it) are taken out again
  // where their carving leaves a void, removed cells that reach neither the hull nor a pole
  // below this: such a void is not a cavity of the object. Chosen on the liver.
  double pole_outside_below = 0.15;
  // Rule 2: a tet stays where its centroid's occupancy ≥ this (and poles there are interior).
  // Below 0.5 because removing a big tet that merely straddles a notch exposes faces deep
  // inside; 0.3 gave the smallest Hausdorff distance on the liver (0.5: 6.2 mm, 0.3: 4.7 mm).
  double inside_from = 0.3;
  // Rule 2 for small tets (longest edge below this, mm): kept only where the centroid is inside
  // (occupancy ≥ 0.5). 0 = never; build_refined_mesh makes 0 2 × the largest voxel spacing.
  double small_tet_edge_mm = 0;
  bool remove_outside_tets = true;  // rule 2 on/off; cells it removes that the outside does not
                                    // reach (through removed cells) are kept again
  // Rule 2 also removes the tets containing these points (world, mm): places known to be
  // outside where the centroid test fails (fidelity refinement finds them).
  std::vector<Vec3> outside_points;
  // Lloyd sites can be exactly coplanar and cospherical (centroids of symmetric voxel sets);
  // Delaunay then has flat tets. Interior points are nudged by up to this (mm), with a
  // deterministic hash of their index (in the first I) and the seed, before triangulation.
  double interior_jitter_mm = 1e-3;
  std::uint64_t seed = 1;
  bool repair_manifold = true;      // rule 3: delete samples where the boundary pinches, then
                                    // peel whatever pinch remains, so it is a closed 2-manifold
  int max_pinch_passes = 100;       // rounds of sample deletion before peeling takes over: a
                                    // round costs what it changes, a peeling pass every tet;
                                    // a larger boundary can need more rounds
  double min_component_fraction = 0.01;  // rule 4: drop tet groups below this volume fraction
                                         // of the largest (stray slivers)
};

struct MeshGenerationResult {
  TetMesh mesh;                           // vertices: used samples of B then I (world, mm)
  std::vector<Vec3> exterior_poles;       // EP (world, mm)
  std::vector<Vec3> interior_poles;       // poles found inside the object (not inserted)
  std::size_t near_surface_poles = 0;     // slit poles taken out again (they carved a void)
  std::vector<std::array<Vec3, 4>> removed_outside;  // tets removed by rule 2, for the viewer
  std::size_t delaunay_tets = 0;          // finite tets of Delaunay(B ∪ EP ∪ I)
  std::size_t removed_by_poles = 0;       // rule 1: incident to a pole
  std::size_t removed_by_centroid = 0;    // rule 2
  std::vector<Vec3> pinched_samples;      // rule 3: samples deleted where the boundary pinched
  ManifoldRepairReport repair;            // rule 3, fallback: peeling of what still pinches
  std::size_t removed_small_components = 0;            // tets removed by rule 4
  std::vector<std::array<Vec3, 4>> removed_by_repair;  // tets removed by rules 3–4, for the viewer
  std::size_t unused_samples = 0;         // samples of B ∪ I no kept tet references
  std::vector<int> vertex_source;         // for each mesh vertex: index into B, or |B| + index
                                          // in I (the samples the mesh was built from)
  std::vector<std::uint8_t> on_boundary;  // for each mesh vertex: 1 if on the boundary surface
  long long boundary_euler = 0;  // Euler characteristic (V − E + F) of the boundary surface
                                          // (from the cells' adjacency: no face sort)
};

// Stage 5 kept open for refinement: samples can be added to B and dropped from I, and the
// triangulations change only where they must (poles of the samples around the new ones,
// their cells), instead of being built again.
class DelaunayMesher {
 public:
  DelaunayMesher(const std::vector<Vec3>& surface_samples, const std::vector<Vec3>& interior_samples,
                 const OccupancyFunction& occupancy, const MeshGenerationOptions& options = {},
                 const Progress& progress = {});
  ~DelaunayMesher();
  DelaunayMesher(const DelaunayMesher&) = delete;
  DelaunayMesher& operator=(const DelaunayMesher&) = delete;

  // Rules 1–4 on the current triangulation. Samples rule 3 deletes stay deleted until the
  // next refine(), which puts them back.
  MeshGenerationResult mesh();

  // Appends samples to B, drops samples of I (indices into the current I; the others keep
  // their order), and adds points for rule 2's outside_points. Vertex indices of later meshes
  // are into the new B then I. The result is the mesh a fresh build of the refined samples
  // would give, except that interior samples keep the jitter of their first index and hull
  // poles keep the first B's distance scale. After an exception (a cancel, a bad index) the
  // mesher must not be used again.
  void refine(const std::vector<Vec3>& new_surface_samples, const std::vector<int>& dropped_interior,
              const std::vector<Vec3>& outside_points);

 private:
  struct State;
  std::unique_ptr<State> s_;
};

MeshGenerationResult build_delaunay_mesh(const std::vector<Vec3>& surface_samples,
                                         const std::vector<Vec3>& interior_samples,
                                         const OccupancyFunction& occupancy,
                                         const MeshGenerationOptions& options = {},
                                         const Progress& progress = {});

}  // namespace cvt
