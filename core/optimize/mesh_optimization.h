// Stage 6 (paper IV: "apply local optimization for the worst case guarantee"): local mesh
// improvement that removes slivers and other bad tets from the stage-5 mesh. A tet is bad when
// a dihedral angle is below target_dihedral_deg (or above 180° minus it) or a Table I measure is
// in its bad bin; each pass, worst tets first:
//   0. boundary vertices off the surface (interior sites the Delaunay exposed) are moved onto
//      it, as far as their star allows, and slide from then on;
//   1. flips: edge removal (3-2, 4-4, … the ring re-triangulated by dynamic programming), 2-3
//      face flips, boundary edge flips where the boundary is convex (the diagonal of two
//      boundary triangles swapped, only when the new triangles follow the segmentation surface),
//      and removal of corner tets (a spike of one tet on the surface, with its corner vertex);
//      then the short edge of needles collapsed (a vertex removed) where the link condition
//      holds;
//   2. in the first passes, for a better overall distribution, one global ODT sweep over the
//      interior vertices (towards the volume-weighted mean of their tets' circumcentres), and
//      flips on mediocre tets as well as bad ones;
//   3. vertex moves that raise the worst tet of a star: interior vertices freely, boundary
//      vertices along the sub-voxel surface (0.5 level of the smoothed indicator);
//   4. where none of that helped (needles on tiny boundary triangles, wedges across thick parts
//      with no vertex inside), an interior vertex is inserted (cavity + star re-triangulation);
//   5. after the last pass, the boundary is fitted to the surface: its vertices move along the
//      normal off the level set so that the triangles, not only their corners, follow it
//      (least squares; no tet turns bad).
// A change is kept only when the worst tet it makes is better than the worst it replaces (ODT
// and snapping: no tet turns bad, no bad tet gets worse), so the worst tet never gets worse
// (once no tet is bad, none turns bad); new tets are positively oriented and fill the region of
// the ones they replace, so validity and the boundary's topology are kept. Input vertices keep
// their order (only removed corners and collapsed vertices leave gaps, see
// OptimizationResult::vertex_origin); inserted ones are appended. Deterministic: the same mesh
// and options give the same result, whatever the thread count.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "optimize/optimization_options.h"
#include "base/progress.h"
#include "base/tet_mesh.h"
#include "base/volume.h"

namespace cvt {

namespace opt {
class WorkMesh;
class LevelSetSurface;
class BoundaryRefiner;
class MaskSurface;
}  // namespace opt


// Figures of the mesh after one pass (or before the first).
struct PassStats {
  int pass = 0;       // 0: before optimisation
  double wall_s = 0;  // time of this pass (statistics not included)
  double flips_s = 0, odt_s = 0, smoothing_s = 0, insertion_s = 0;  // … of which each phase
  double cpu_s = 0;  // process CPU time of the pass (all threads)
  std::size_t tets = 0;
  double min_dihedral_deg = 0, max_dihedral_deg = 0;
  // Smallest quality the optimiser works with: the minimum over the tets of min(smallest sine of
  // a dihedral angle / sine of target_dihedral_deg, each Table I measure / its bad-bin edge);
  // a tet is bad below 1. While below 1 it never decreases from pass to pass; once above, it
  // stays above.
  double min_quality = 0;
  // When has_statistics (every pass with pass statistics, else the first and last):
  std::size_t below_5 = 0, below_10 = 0, below_15 = 0, below_20 = 0;  // min dihedral below (°)
  std::array<std::array<double, 3>, 3> bins_percent{};  // Table I bins, kShewchukMeasures order
  bool has_statistics = false;  // the figures above and the dihedral range were computed
  // What the pass did.
  std::size_t edge_removals = 0, face_flips = 0, boundary_flips = 0;
  std::size_t corner_removals = 0;  // corner tets removed with their corner vertex
  std::size_t collapsed_edges = 0;  // short edges of needles collapsed (a vertex removed)
  std::size_t odt_moved = 0;        // interior vertices moved by the ODT sweep
  std::size_t moved_interior = 0, moved_surface = 0;  // … and to raise a bad tet
  std::size_t snapped_surface = 0;  // fixed boundary vertices brought onto the surface
  std::size_t inserted = 0;                           // interior vertices inserted
  // Boundary refinement (passes 2 and 3): points of the segmentation's boundary beyond the
  // tolerance before it, and boundary vertices inserted.
  std::size_t far_boundary_points = 0, inserted_boundary = 0;
  std::size_t split_caps = 0;  // bad boundary caps split at their ridge (a boundary vertex each)
  std::size_t vertices = 0;                           // after the pass
};

struct OptimizationResult {
  std::vector<PassStats> history;  // [0]: the input mesh, then one entry per pass
  double wall_s = 0;               // total optimisation time (statistics not included) …
  double setup_s = 0;              // … of which setting up (adjacency, qualities, surface)
  double cpu_s = 0;                // … as process CPU time (all threads)
  // Largest distance (mm) from a boundary vertex that may slide to the 0.5 level set, before
  // and after (before the fit, which moves them off it on purpose); boundary vertices off the surface at the start (fixed until snapped onto it)
  // are counted apart.
  double surface_distance_before_mm = 0, surface_distance_after_mm = 0;
  std::size_t sliding_vertices = 0, fixed_boundary_vertices = 0;
  double fixed_boundary_distance_mm = 0;  // largest distance of a fixed boundary vertex
  std::size_t snapped_vertices = 0;       // fixed boundary vertices snapped onto the surface
  // Boundary flips and corner removals: the largest height of a tet cut off (how far the
  // boundary moved), and the largest distance of a new boundary triangle's centroid to the
  // surface; of the flips whose new faces are beyond the tolerance, the largest distance of
  // the faces they replaced (the new ones are no farther).
  double max_boundary_shift_mm = 0;
  double max_flip_face_distance_mm = 0;
  double max_flip_replaced_distance_mm = 0;
  std::size_t boundary_flips = 0;
  std::size_t corner_removals = 0;    // corner tets (three boundary faces around a vertex with
                                      // no other tet) removed with that vertex
  std::size_t collapsed_edges = 0;    // short edges collapsed, a vertex removed with each
  std::size_t inserted_vertices = 0;  // interior vertices inserted
  std::size_t inserted_boundary_vertices = 0;  // boundary vertices inserted where the
                                               // segmentation departs from the boundary …
  double boundary_tolerance_mm = 0;            // … farther than this (0: no refinement)
  std::size_t split_caps = 0;  // bad boundary caps split at their ridge
  // The boundary's fit to the surface after the last pass: vertices moved, their mean and
  // largest offset, the boundary triangles' area-weighted mean distance to the level set
  // before and after, and its time (included in wall_s and in the last pass's smoothing_s).
  std::size_t fit_vertices = 0;
  double fit_mean_offset_mm = 0, fit_max_offset_mm = 0;
  double fit_error_before_mm = 0, fit_error_after_mm = 0;
  double fit_s = 0;
  // For each vertex of the optimised mesh, the input vertex it is (−1: inserted). Input
  // vertices keep their order; only removed corners and collapsed vertices leave gaps (an
  // inserted vertex may be collapsed too). (Filled by optimize_mesh;
  // MeshOptimizer::mesh gives it too.)
  std::vector<std::int32_t> vertex_origin;
};

// Steps the optimisation pass by pass (for the viewer); optimize_mesh runs it to the end.
class MeshOptimizer {
 public:
  // `indicator` (may be null: boundary vertices then stay fixed) is the smoothed indicator
  // whose 0.5 level is the segmentation's surface; it must outlive the optimiser. Throws
  // InputError for bad options or a mesh with a missing vertex or a tet not positively oriented.
  // With pass_statistics, Table I bins and dihedral figures after every pass, for a viewer's
  // history (not counted in the timings; a pass recomputes the figures only of the tets it
  // touched); without, only before the first pass and after the last (the others get the
  // counts and min_quality).
  // `object` (may be null: the fit then targets the indicator's level set, and the boundary is
  // not refined) is the segmentation whose boundary the last step fits the boundary triangles
  // to and boundary refinement follows; it must outlive the optimiser. A boundary tolerance of 0
  // is resolved from its sizing unit (a scan of the mask; the pipeline passes stage 1's).
  MeshOptimizer(const TetMesh& mesh, const Volume<float>* indicator,
                const OptimizationOptions& options = {}, bool pass_statistics = false,
                const Mask* object = nullptr);
  ~MeshOptimizer();
  MeshOptimizer(const MeshOptimizer&) = delete;
  MeshOptimizer& operator=(const MeshOptimizer&) = delete;

  // Runs one pass; returns false (and does nothing) once finished.
  bool step(const Progress& progress = {});
  // Runs the remaining passes; returns how many ran.
  int run(const Progress& progress = {});
  bool finished() const { return finished_; }
  int passes() const { return int(result_.history.size()) - 1; }

  const std::vector<PassStats>& history() const { return result_.history; }
  // The current mesh; `origin` (if given) receives, for each of its vertices, the input vertex
  // it is (−1: inserted).
  TetMesh mesh(std::vector<std::int32_t>* origin = nullptr) const;
  // The result so far (measures the boundary vertices' distance to the surface now).
  OptimizationResult result() const;

 private:
  PassStats statistics(int pass, bool full);

  // Each tet slot's figures at the last full statistics (clock figures_clock_), so the next
  // recomputes only the tets around what changed since.
  struct TetFigureSummary {
    double min_dihedral = 0, max_dihedral = 0;
    std::array<std::uint8_t, 3> bin{};  // Table I bin (0 bad, 1 middle, 2 good) per measure
  };
  std::vector<TetFigureSummary> figures_;
  std::uint64_t figures_clock_ = 0;

  OptimizationOptions options_;
  bool pass_statistics_ = false;
  std::unique_ptr<opt::WorkMesh> work_;
  std::unique_ptr<opt::LevelSetSurface> surface_;
  std::unique_ptr<opt::MaskSurface> target_;  // what the fit follows (null: surface_)
  double boundary_tolerance_mm_ = 0;          // of boundary refinement, resolved
  std::unique_ptr<opt::BoundaryRefiner> refiner_;
  OptimizationResult result_;
  std::int32_t input_vertices_ = 0;
  bool finished_ = false;
  bool fitted_ = false;  // the fit ran: surface_distance_after_mm was measured before it
};

// Optimises `mesh` in place (`object` as for MeshOptimizer).
OptimizationResult optimize_mesh(TetMesh& mesh, const Volume<float>* indicator,
                                 const OptimizationOptions& options = {},
                                 const Progress& progress = {}, const Mask* object = nullptr);

// {"wall_s","setup_s","cpu_s","surface_distance_before_mm","surface_distance_after_mm",
//  "sliding_vertices","fixed_boundary_vertices","fixed_boundary_distance_mm",
//  "snapped_vertices","max_boundary_shift_mm","max_flip_face_distance_mm",
//  "max_flip_replaced_distance_mm","boundary_flips",
//  "corner_removals","collapsed_edges","inserted_vertices","inserted_boundary_vertices",
//  "boundary_tolerance_mm","split_caps",
//  "fit_vertices","fit_mean_offset_mm",
//  "fit_max_offset_mm","fit_error_before_mm","fit_error_after_mm","fit_s",
//  "passes":[{"pass","wall_s","cpu_s","flips_s","odt_s","smoothing_s","insertion_s","tets",
//  "vertices","min_quality","edge_removals","face_flips","boundary_flips","corner_removals",
//  "collapsed_edges","odt_moved","moved_interior","moved_surface","snapped_surface","inserted",
//  "split_caps","far_boundary_points","inserted_boundary",
//  with statistics: "min_dihedral_deg","max_dihedral_deg","below_deg":{"5","10","15","20"},
//  "bins_percent":{measure key: [3]}}]}
nlohmann::json to_json(const OptimizationResult& result);

}  // namespace cvt
