// The pipeline the CLI and the viewer both drive: it owns the image, the parameters and every
// stage's result (stage.h), knows which stages are stale after a parameter change (that stage
// and all downstream), and can be stepped: one stage, k Lloyd iterations, k optimisation
// passes, or everything. Not thread-safe: the viewer calls it from one worker thread at a time
// and reads results between jobs; cancellation goes through Progress.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "base/image.h"
#include "base/progress.h"
#include "evaluate/fidelity.h"
#include "evaluate/quality.h"
#include "io/image_io.h"
#include "meshing/fidelity_refinement.h"
#include "meshing/mesh_generation.h"
#include "optimize/mesh_optimization.h"
#include "pipeline/parameters.h"
#include "pipeline/stage.h"
#include "preprocess/preprocess.h"
#include "sampling/cvt_sampling.h"
#include "sampling/shallow_points.h"
#include "sampling/surface_sampling.h"

namespace cvt {

// How to read the image (its NIfTI frame), and the options of each stage, from the parameters.
ReadOptions image_read_options(const Parameters& p);
PreprocessOptions preprocess_options(const Parameters& p);
// Stage 2's options need stage 1's result: the automatic lfs cap is its median boundary lfs.
SurfaceSamplingOptions surface_options(const Parameters& p, const PreprocessResult& pre);
// Stage 2: the samples `options` give, and the interior spacing that matches them (0 without
// samples): their area_weighted_spacing_mm without the cap on their radius (lfs cap, chord
// tolerance), which adds surface samples only. Under a cap the samples are drawn a second time
// without it (where capped radii fall below the voxel, every boundary voxel is a sample and
// the area weights no longer hold); both draws are serial greedy loops, so they run side by
// side.
struct SampledSurface {
  SurfaceSamples samples;
  double interior_spacing_mm = 0;
};
SampledSurface sample_surface_and_spacing(const PreprocessResult& pre,
                                          const SurfaceSamplingOptions& options,
                                          const Progress& progress = {});
CvtOptions cvt_options(const Parameters& p, double default_spacing_mm);
MeshGenerationOptions mesh_options(const Parameters& p);
FidelityRefinementOptions refinement_options(const Parameters& p);

// Stage 6's result: the optimised mesh and what the optimiser did.
struct OptimizedMesh {
  TetMesh mesh;
  std::vector<int> vertex_source;  // as stage 5's (into B, or |B| + index in I); −1: inserted
  OptimizationResult optimization;
};

struct StageRecord {
  std::string name;  // stage_name, or a part of a stage (kQualityRecord ... in stage.h)
  double wall_s = 0;
  double peak_rss_mb = 0;  // process peak so far, when the stage ended
};

class Pipeline {
 public:
  // How the pipeline will be run. `repeatable`: it keeps the image and every stage's
  // intermediate results (the viewer re-runs stages and shows the fields). `once`: a single
  // run through the stages, which frees each input after its last stage has used it (the
  // image once stage 1 has selected the object, the medial axis after stage 1, the lfs after
  // stage 3, the Lloyd stepper's voxels after stage 4, the feature transform after stage 5),
  // so the run's peak memory is lower. Re-running a stage whose input was freed throws
  // InputError.
  enum class Run { repeatable, once };
  // Makes every stage stale.
  void set_image(std::shared_ptr<const Image> image, Run run = Run::repeatable);
  const Image* image() const { return image_.get(); }  // null after a once-run's stage 1

  const Parameters& parameters() const { return parameters_; }
  // Validates (InputError naming the key) and marks stale the first stage whose result the
  // change affects, and everything downstream.
  void set_parameters(const Parameters& parameters);

  bool is_stale(Stage s) const { return !done_[int(s)]; }
  // Runs every stale stage up to and including `last`.
  void run_through(Stage last, const Progress& progress = {});
  void run_all(const Progress& progress = {}) { run_through(Stage::evaluate, progress); }

  // Lloyd stepping (stage 3): runs stages 1–2 if stale, starts the stepper if needed, then k
  // iterations (or to convergence with k < 0); later stages become stale. Returns iterations.
  int step_lloyd(int k, const Progress& progress = {});
  // Stage 6 stepping, with optimisation on (else InputError): runs stages 1–5 if stale,
  // starts the optimiser on the stage-5 mesh if needed, then k passes (to the end with k < 0);
  // optimized() follows every call, evaluation becomes stale, and stage 6 is done once the
  // optimiser has finished. Returns the passes run.
  int step_optimization(int k, const Progress& progress = {});
  // Table I and dihedral figures after every pass of stage 6 (the viewer's history).
  void set_pass_statistics(bool on) { pass_statistics_ = on; }
  // Stage 7 always measures element quality (a tenth of a second); the fidelity to the
  // segmentation only when asked, as it costs about as much as a stage. Off by default.
  void set_evaluate_fidelity(bool on);
  bool evaluates_fidelity() const { return evaluate_fidelity_; }

  // Results (null until the stage has run).
  const PreprocessResult* preprocess() const { return preprocess_.get(); }
  // Stage 1's result shared, so a viewer can show its volumes without copying them. A
  // repeatable pipeline never changes a result once made (a re-run makes a new one); only a
  // once-run frees fields of it in place, and nobody shares those.
  std::shared_ptr<const PreprocessResult> shared_preprocess() const { return preprocess_; }
  const SurfaceSamples* surface() const { return surface_.get(); }
  const LloydStepper* lloyd() const { return lloyd_.get(); }
  const ShallowResult* shallow() const { return shallow_.get(); }
  const RefinedMesh* mesh() const { return mesh_.get(); }            // stage 5
  const OptimizedMesh* optimized() const { return optimized_.get(); }  // stage 6, when on
  const QualityReport* quality() const { return quality_.get(); }
  const FidelityReport* fidelity() const { return fidelity_.get(); }
  // The mesh the pipeline makes: stage 6's when it ran, else stage 5's (null before both).
  const TetMesh* final_mesh() const;
  // Counts every change of `s`'s result (a run, a Lloyd step, an optimisation pass, a reset),
  // so a viewer can tell a new result without comparing addresses.
  std::uint64_t generation(Stage s) const { return generation_[int(s)]; }
  // Default interior spacing: sample_surface_and_spacing's for stage 2's samples (0 before).
  double default_interior_spacing_mm() const { return interior_spacing_mm_; }
  // The parameters as the stages use them: with --vertices (target_vertices), the r and the
  // interior points it chose, once stages 2 and 3 have resolved them.
  Parameters sized_parameters() const;

  const std::vector<StageRecord>& records() const { return records_; }

 private:
  void run_stage(Stage s, const Progress& progress);
  void evaluate(const Progress& progress);
  void invalidate_from(Stage s);
  void free_inputs_used_up_by(Stage s);  // in a once-run
  void start_lloyd();
  double budget_r() const;  // --vertices: the r of stage 2
  int run_lloyd(int k, const Progress& progress);        // k < 0: to convergence
  int optimize_passes(int k, const Progress& progress);  // k < 0: to the end
  void record(std::string name, double wall_s);

  std::shared_ptr<const Image> image_;
  Run run_ = Run::repeatable;
  Parameters parameters_;
  double budget_r_ = 0;               // --vertices: stage 2's r (0: none yet)
  double interior_spacing_mm_ = 0;    // default_interior_spacing_mm, set by stage 2
  std::int64_t budget_points_ = 0;    // … and stage 3's interior points
  bool done_[kStageCount] = {};
  std::uint64_t generation_[kStageCount] = {};
  std::shared_ptr<PreprocessResult> preprocess_;
  std::unique_ptr<SurfaceSamples> surface_;
  std::unique_ptr<LloydStepper> lloyd_;
  std::unique_ptr<ShallowResult> shallow_;
  std::unique_ptr<RefinedMesh> mesh_;
  std::unique_ptr<MeshOptimizer> optimizer_;  // while stage 6 is part way or done
  std::unique_ptr<OptimizedMesh> optimized_;
  bool pass_statistics_ = false;
  bool evaluate_fidelity_ = false;
  std::unique_ptr<QualityReport> quality_;
  std::unique_ptr<FidelityReport> fidelity_;
  std::vector<StageRecord> records_;
};

}  // namespace cvt
