// What the views draw, copied out of the Pipeline. The Pipeline is not thread-safe and lives on
// the worker thread; after each job (and after each Lloyd iteration) the worker builds an
// immutable SceneData snapshot and hands it to the UI thread, which only ever reads snapshots.
// Parts whose stage did not run again are shared with the previous snapshot (shared_ptr), so a
// Lloyd step does not copy the volumes again. GL-free.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include "clip_selection.h"
#include "fields/marching_cubes.h"
#include "pipeline/pipeline.h"

namespace cvt::render {

// Stage 1 results on the cropped grid, for the slice overlays and the early 3D surface. The
// volumes are the pipeline's own, shared (each pointer keeps its whole stage-1 result alive),
// not copies: a snapshot after stage 1 costs no copy of the volumes.
struct VolumeLayers {
  Grid grid;                                  // the cropped (and padded) object grid
  std::array<int, 3> offset{};                // image voxel of crop voxel (0,0,0)
  std::shared_ptr<const Mask> object;         // 1 inside
  std::shared_ptr<const Volume<float>> lfs_mm;  // clamped local feature size
  std::shared_ptr<const Mask> medial_axis;    // 1 inner, 2 outer
  LfsBounds lfs_bounds{0, 0};      // the colormap range of lfs_mm
  TriangleSurface object_surface;  // object_surface_preview (world mm)
  CleanupReport cleanup;           // what the clean-up dropped, filled and kept
};

// The Lloyd state (stage 3) at one iteration.
struct LloydState {
  // Which state this is (see SceneData::generation); it has its own because live states come
  // between snapshots.
  std::uint64_t generation = 0;
  Grid grid;                      // the cropped grid the sites live on
  std::vector<Vec3> sites_world;  // mm
  std::vector<Vec3> sites_local;  // mm, spacing ⊙ index (for discrete Voronoi labels)
  std::vector<IterationStats> history;
  CvtResolved resolved;
  bool converged = false;
};

// Per-tet values of every Measure, in enum order, exactly as core bins them: the stage-5 mesh's
// beside the optimised one (for before/after figures), and every drawn mesh's.
struct MeshMeasures {
  std::size_t vertices = 0, tets = 0;
  std::array<std::vector<double>, kMeasureCount> measures;
};

// A drawn mesh, with its measures for colouring and highlighting. A MeshMeasures, so that once
// stage 6 runs, the stage-5 mesh's measures are the last snapshot's, shared.
struct MeshLayers : MeshMeasures {
  TetMesh mesh;              // world mm
  TetNeighbours neighbours;  // for the faces a clip exposes
  std::vector<Vec3> exterior_poles;
  Vec3 lo, hi;  // bounding box of the vertices
};

// The snapshot that built each part (a part kept from an earlier snapshot keeps its number; 0:
// no such part). Readers that cache what they made of a part (GPU buffers, a slice picture,
// figures) tell a new part by its number, never by its address.
struct PartGenerations {
  std::uint64_t image = 0, volumes = 0, surface = 0, shallow = 0, mesh = 0, optimization = 0,
                unoptimized = 0, quality = 0, fidelity = 0;
  bool operator==(const PartGenerations&) const = default;
};

struct SceneData {
  // Snapshots of one builder count from 1 (0: not made by a builder); Lloyd states share the
  // count, so no two things a builder made have the same number.
  std::uint64_t generation = 0;
  PartGenerations generations;
  std::shared_ptr<const Image> image;                // null before an image is loaded
  std::map<std::int64_t, std::size_t> label_counts;  // integer images: voxels per label
  ValueRange value_range;
  Parameters parameters;                  // as applied to the pipeline
  Parameters sized_parameters;            // as the stages use them (--vertices resolved)
  std::array<bool, kStageCount> stale{};  // Pipeline::is_stale per stage
  std::vector<StageRecord> records;
  double default_interior_spacing_mm = 0;
  std::shared_ptr<const VolumeLayers> volumes;
  std::shared_ptr<const std::vector<Vec3>> surface_samples;  // B (world mm)
  std::shared_ptr<const std::vector<Vec3>> surface_voxel_samples;  // B at voxel centres (world)
  std::shared_ptr<const LloydState> lloyd;                         // made anew for every snapshot
  std::shared_ptr<const ShallowResult> shallow;
  std::shared_ptr<const MeshLayers> mesh;  // the final mesh: stage 6's once it ran
  // Stage 6: its options as applied, its result so far (per-pass history), and the stage-5
  // mesh's measures (null until stage 6 started), for before/after figures.
  std::shared_ptr<const OptimizationResult> optimization;
  std::shared_ptr<const MeshMeasures> unoptimized;
  std::shared_ptr<const QualityReport> quality;
  std::shared_ptr<const FidelityReport> fidelity;
};

// Seconds the latest run of `stage` took (its parts summed), or a negative value if none.
double stage_seconds(const std::vector<StageRecord>& records, Stage stage);

// Builds snapshots of one Pipeline, reusing what did not change. Call only from the thread that
// owns the Pipeline, between its operations.
class SceneDataBuilder {
 public:
  // `image` is the image the pipeline was given (shared so snapshots keep it alive).
  std::shared_ptr<const SceneData> update(const Pipeline& pipeline,
                                          std::shared_ptr<const Image> image);
  std::shared_ptr<const SceneData> last() const { return last_; }
  // The stepper's state now, numbered after everything this builder made so far (the worker
  // posts it between snapshots).
  std::shared_ptr<const LloydState> lloyd_state(const LloydStepper& stepper);

 private:
  std::shared_ptr<const SceneData> last_;
  std::uint64_t generation_ = 0;  // the last number given out
  // Pipeline::generation of each stage at the last snapshot.
  std::array<std::uint64_t, kStageCount> seen_{};
};

std::shared_ptr<const LloydState> make_lloyd_state(const LloydStepper& stepper,
                                                   std::uint64_t generation);
std::shared_ptr<const VolumeLayers> make_volume_layers(
    std::shared_ptr<const PreprocessResult> pre, const Grid& image_grid);
std::shared_ptr<const MeshLayers> make_mesh_layers(const TetMesh& mesh,
                                                   const std::vector<Vec3>& exterior_poles);
std::shared_ptr<const MeshMeasures> make_mesh_measures(const TetMesh& mesh);

}  // namespace cvt::render
