// The pipeline the CLI and the viewer both drive: it owns the image, the parameters and every
// stage's result, knows which stages are stale after a parameter change (that stage and all
// downstream), and can be stepped: one stage, k Lloyd iterations, or everything. Not
// thread-safe: the viewer calls it from one worker thread at a time and reads results between
// jobs; cancellation goes through Progress.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sampling/cvt_sampling.h"
#include "evaluate/fidelity.h"
#include "meshing/fidelity_refinement.h"
#include "base/image.h"
#include "meshing/mesh_generation.h"
#include "optimize/mesh_optimization.h"
#include "pipeline/parameters.h"
#include "preprocess/preprocess.h"
#include "base/progress.h"
#include "evaluate/quality.h"
#include "sampling/shallow_points.h"
#include "sampling/surface_sampling.h"

namespace cvt {

enum class Stage { preprocess, surface, cvt, shallow, mesh, evaluate, count };
inline constexpr int kStageCount = int(Stage::count);
const char* stage_name(Stage stage);

// The first stage whose result depends on a parameter that differs (Stage::count if none).
Stage first_changed_stage(const Parameters& a, const Parameters& b);

// Options of each stage from the flat parameters.
PreprocessOptions preprocess_options(const Parameters& p);
SurfaceSamplingOptions surface_options(const Parameters& p);
CvtOptions cvt_options(const Parameters& p, double default_spacing_mm);
MeshGenerationOptions mesh_options(const Parameters& p);
FidelityRefinementOptions refinement_options(const Parameters& p);

struct StageRecord {
  std::string name;
  double wall_s = 0;
  double peak_rss_mb = 0;  // process peak so far, when the stage ended
};

class Pipeline {
 public:
  void set_image(std::shared_ptr<const Image> image);  // makes every stage stale
  const Image* image() const { return image_.get(); }

  const Parameters& parameters() const { return parameters_; }
  // Validates (InputError naming the key) and marks the affected stages stale.
  void set_parameters(const Parameters& parameters);

  bool is_stale(Stage s) const { return !done_[int(s)]; }
  // Runs every stale stage up to and including `last`.
  void run_through(Stage last, const Progress& progress = {});
  void run_all(const Progress& progress = {}) { run_through(Stage::evaluate, progress); }

  // Lloyd stepping (stage 3): runs stages 1–2 if stale, starts the stepper if needed, then k
  // iterations (or to convergence with k < 0); later stages become stale. Returns iterations.
  int step_lloyd(int k, const Progress& progress = {});

  // Stage 6 stepping (viewer), with optimize = "default" (else InputError): runs the stages up
  // to 4 if stale and stage 5 if needed, starts the optimiser on the stage-5 mesh if needed,
  // then k passes (to the end with k < 0); mesh() follows after every call, evaluation becomes
  // stale, and the mesh stage is done once the optimiser has finished. Returns passes run.
  int step_optimization(int k, const Progress& progress = {});
  // Stage 6's options are parameters.optimization: changing only them restarts stage 6 from
  // the kept stage-5 mesh. Per-pass statistics (the viewer's history) are not a parameter.
  void set_pass_statistics(bool on) { pass_statistics_ = on; }

  // Results (null / empty until the stage has run).
  const PreprocessResult* preprocess() const { return preprocess_.get(); }
  const SurfaceSamples* surface() const { return surface_.get(); }
  const LloydStepper* lloyd() const { return lloyd_.get(); }
  const ShallowResult* shallow() const { return shallow_.get(); }
  const MeshGenerationResult* mesh() const { return mesh_.get(); }
  const OptimizationResult* optimization() const { return optimization_.get(); }  // stage 6
  // The stage-5 mesh before stage 6 (null unless stage 6 started), for before/after figures.
  const MeshGenerationResult* unoptimized_mesh() const { return unoptimized_.get(); }
  const QualityReport* quality() const { return quality_.get(); }
  const FidelityReport* fidelity() const { return fidelity_.get(); }
  // Default interior spacing: the area-weighted mean spacing r·lfs of the surface samples.
  double default_interior_spacing_mm() const;

  const std::vector<StageRecord>& records() const { return records_; }

 private:
  void run_stage(Stage s, const Progress& progress);
  void invalidate_from(Stage s);
  void start_lloyd();
  void start_optimization();                           // mesh_ becomes the kept stage-5 mesh's copy
  void restart_optimization();                         // from the kept stage-5 mesh, no pass yet
  int optimize_passes(int k, const Progress& progress);  // k < 0: to the end

  std::shared_ptr<const Image> image_;
  Parameters parameters_;
  bool done_[kStageCount] = {};
  std::unique_ptr<PreprocessResult> preprocess_;
  std::unique_ptr<SurfaceSamples> surface_;
  std::unique_ptr<LloydStepper> lloyd_;
  std::unique_ptr<ShallowResult> shallow_;
  std::unique_ptr<MeshGenerationResult> mesh_;
  std::unique_ptr<OptimizationResult> optimization_;
  std::unique_ptr<MeshGenerationResult> unoptimized_;  // stage 5's mesh, once stage 6 started
  std::unique_ptr<MeshOptimizer> optimizer_;           // while stage 6 is part way
  bool pass_statistics_ = false;
  int first_passes_ = -1;  // passes the mesh stage runs of stage 6 (step_optimization: 0)
  std::unique_ptr<QualityReport> quality_;
  std::unique_ptr<FidelityReport> fidelity_;
  std::vector<StageRecord> records_;
};

}  // namespace cvt
