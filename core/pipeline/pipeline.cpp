#include "pipeline/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "base/errors.h"
#include "base/memory.h"
#include "fields/smoothing.h"

namespace cvt {

const char* stage_name(Stage stage) {
  static const char* names[] = {"preprocess", "surface sampling", "CVT sampling",
                                "shallow points", "mesh generation", "evaluation"};
  return names[int(stage)];
}

PreprocessOptions preprocess_options(const Parameters& p) {
  PreprocessOptions o;
  o.selection.labels = p.labels;
  o.selection.iso = p.iso;
  o.selection.inside_above = p.inside_above;
  o.selection.margin_voxels = p.margin_voxels;
  o.cleanup.remove_small_components = p.remove_small_components;
  o.cleanup.min_component_fraction = p.min_component_fraction;
  o.cleanup.fill_cavities = p.fill_cavities;
  o.smoothing_sigma_mm = p.smoothing_sigma_mm;
  o.medial_axis.min_separation_mm = p.medial_min_separation_mm;
  o.medial_axis.min_angle_deg = p.medial_min_angle_deg;
  o.lfs.min_mm = p.lfs_min_mm;
  o.lfs.max_mm = p.lfs_max_mm;
  o.max_bytes = std::size_t(p.max_memory_mb * 1024.0 * 1024.0);
  return o;
}

SurfaceSamplingOptions surface_options(const Parameters& p) {
  SurfaceSamplingOptions o;
  o.r = p.r;
  o.sigma_mm = p.sigma_surface_mm;
  o.project_to_surface = p.project_samples;
  return o;
}

CvtOptions cvt_options(const Parameters& p, double default_spacing_mm) {
  CvtOptions o;
  o.sigma_density_mm = p.sigma_density_mm;
  o.interior_spacing_mm = p.interior_spacing_mm > 0 ? p.interior_spacing_mm : default_spacing_mm;
  o.interior_points = p.interior_points;
  o.epsilon_mm = p.epsilon_mm;
  o.max_iterations = p.max_iterations;
  o.seed = p.seed;
  return o;
}

FidelityRefinementOptions refinement_options(const Parameters& p) {
  FidelityRefinementOptions o;
  o.max_rounds = p.fidelity_rounds;
  o.tolerance_mm = p.fidelity_tolerance_mm;
  o.r = p.r;
  return o;
}

MeshGenerationOptions mesh_options(const Parameters& p) {
  MeshGenerationOptions o;
  o.min_component_fraction = p.remove_small_components ? p.min_component_fraction : 0.0;
  o.seed = p.seed;
  return o;
}

Stage first_changed_stage(const Parameters& a, const Parameters& b) {
  // Compare each stage's own options; stages are listed upstream first.
  const auto same_pre = [&] {
    Parameters x = a, y = b;
    return x.labels == y.labels && x.iso == y.iso && x.inside_above == y.inside_above &&
           x.margin_voxels == y.margin_voxels &&
           x.remove_small_components == y.remove_small_components &&
           x.min_component_fraction == y.min_component_fraction &&
           x.fill_cavities == y.fill_cavities && x.smoothing_sigma_mm == y.smoothing_sigma_mm &&
           x.medial_min_separation_mm == y.medial_min_separation_mm &&
           x.medial_min_angle_deg == y.medial_min_angle_deg && x.lfs_min_mm == y.lfs_min_mm &&
           x.lfs_max_mm == y.lfs_max_mm;
  };
  if (!same_pre()) return Stage::preprocess;
  if (a.r != b.r || a.sigma_surface_mm != b.sigma_surface_mm ||
      a.project_samples != b.project_samples)
    return Stage::surface;
  if (a.sigma_density_mm != b.sigma_density_mm || a.interior_spacing_mm != b.interior_spacing_mm ||
      a.interior_points != b.interior_points || a.epsilon_mm != b.epsilon_mm ||
      a.max_iterations != b.max_iterations || a.seed != b.seed)
    return Stage::cvt;
  if (a.fidelity_rounds != b.fidelity_rounds || a.fidelity_tolerance_mm != b.fidelity_tolerance_mm ||
      a.optimize != b.optimize)  // stage 6 runs inside the mesh stage
    return Stage::mesh;
  return Stage::count;  // threads and the guards do not change results
}

void Pipeline::set_image(std::shared_ptr<const Image> image) {
  image_ = std::move(image);
  invalidate_from(Stage::preprocess);
}

void Pipeline::set_parameters(const Parameters& parameters) {
  validate(parameters);
  const Stage changed = first_changed_stage(parameters_, parameters);
  const bool restart = parameters.optimization != parameters_.optimization;
  parameters_ = parameters;
  if (changed != Stage::count) invalidate_from(changed);
  if (restart && changed > Stage::mesh) restart_optimization();
}

void Pipeline::invalidate_from(Stage s) {
  for (int i = int(s); i < kStageCount; ++i) done_[i] = false;
  switch (s) {  // drop results that no longer match (each case falls through downstream)
    case Stage::preprocess: preprocess_.reset(); [[fallthrough]];
    case Stage::surface: surface_.reset(); [[fallthrough]];
    case Stage::cvt: lloyd_.reset(); [[fallthrough]];
    case Stage::shallow: shallow_.reset(); [[fallthrough]];
    case Stage::mesh:
      optimizer_.reset();
      mesh_.reset();
      unoptimized_.reset();
      optimization_.reset();
      [[fallthrough]];
    case Stage::evaluate:
      quality_.reset();
      fidelity_.reset();
      [[fallthrough]];
    case Stage::count: break;
  }
}

double Pipeline::default_interior_spacing_mm() const {
  if (!surface_ || surface_->voxels.empty()) return 0;
  // Samples crowd where lfs is small, so weight each one's spacing s = r·lfs by the surface
  // area it covers (∝ s²): Σ s³ / Σ s². The interior then matches the bulk of the surface.
  double s2 = 0, s3 = 0;
  for (std::int32_t v : surface_->voxels) {
    const double s = parameters_.r * preprocess_->lfs_mm.data[v];
    s2 += s * s;
    s3 += s * s * s;
  }
  return s3 / s2;
}

void Pipeline::start_lloyd() {
  const CvtOptions options = cvt_options(parameters_, default_interior_spacing_mm());
  const CvtResolved r = resolve_cvt_options(options, preprocess_->object);
  if (r.sites > parameters_.max_points)
    throw InputError("interior points: " + std::to_string(r.sites) + " needed (spacing " +
                     std::to_string(r.spacing_mm) + " mm) exceed max_points = " +
                     std::to_string(parameters_.max_points) +
                     "; raise --interior-spacing or --max-points");
  lloyd_ = std::make_unique<LloydStepper>(*preprocess_, options);
  lloyd_->initialize();
}

void Pipeline::run_stage(Stage s, const Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  switch (s) {
    case Stage::preprocess:
      if (!image_) throw InputError("no image loaded");
      preprocess_ = std::make_unique<PreprocessResult>(
          cvt::preprocess(*image_, preprocess_options(parameters_), progress));
      break;
    case Stage::surface:
      surface_ = std::make_unique<SurfaceSamples>(
          sample_surface(*preprocess_, surface_options(parameters_), progress));
      break;
    case Stage::cvt:
      if (!lloyd_) start_lloyd();
      lloyd_->run_to_convergence(progress);
      break;
    case Stage::shallow:
      shallow_ = std::make_unique<ShallowResult>(remove_shallow_points(
          lloyd_->sites_world(), lloyd_->owners_of(preprocess_->boundary)));
      break;
    case Stage::mesh: {
      if (optimizer_) {  // stage 6 stepped part way (viewer): it goes on from where it is
        optimize_passes(-1, progress);
        break;
      }
      mesh_ = std::make_unique<MeshGenerationResult>(
          build_refined_mesh(*preprocess_, surface_->world, shallow_->kept_world,
                             mesh_options(parameters_), refinement_options(parameters_), progress));
      // Stage 6 (optional) starts from the stage-5 mesh, which is kept for before/after figures.
      if (parameters_.optimize == "default") {
        start_optimization();
        optimize_passes(first_passes_, progress);
      }
      break;
    }
    case Stage::evaluate: {
      // Two records, so element quality and the (slower) fidelity are timed apart.
      progress("quality", 0.0);
      quality_ = std::make_unique<QualityReport>(compute_quality(mesh_->mesh));
      const std::chrono::duration<double> q = std::chrono::steady_clock::now() - t0;
      records_.push_back({"quality", q.count(), double(peak_rss_bytes()) / (1024.0 * 1024.0)});
      progress("fidelity", 0.5);
      const auto t1 = std::chrono::steady_clock::now();
      fidelity_ = std::make_unique<FidelityReport>(
          compute_fidelity(mesh_->mesh, preprocess_->object, {}, progress));
      const std::chrono::duration<double> f = std::chrono::steady_clock::now() - t1;
      records_.push_back({"fidelity", f.count(), double(peak_rss_bytes()) / (1024.0 * 1024.0)});
      done_[int(s)] = true;
      return;
    }
    case Stage::count: break;
  }
  done_[int(s)] = true;
  const std::chrono::duration<double> d = std::chrono::steady_clock::now() - t0;
  records_.push_back({stage_name(s), d.count(), double(peak_rss_bytes()) / (1024.0 * 1024.0)});
}

void Pipeline::run_through(Stage last, const Progress& progress) {
  for (int s = 0; s <= int(last); ++s)
    if (!done_[s]) run_stage(Stage(s), progress);
}

void Pipeline::start_optimization() {
  unoptimized_ = std::move(mesh_);
  mesh_ = std::make_unique<MeshGenerationResult>(*unoptimized_);
  optimizer_ = std::make_unique<MeshOptimizer>(unoptimized_->mesh, &preprocess_->indicator,
                                               parameters_.optimization, pass_statistics_);
}

int Pipeline::optimize_passes(int k, const Progress& progress) {
  progress("optimisation", 0.0);
  int done = 0;
  // The mesh follows the optimiser also after a cancel (every phase of a pass keeps it valid).
  auto adopt = [&] {
    auto result = std::make_unique<OptimizationResult>(optimizer_->result());
    mesh_->mesh = optimizer_->mesh(&result->vertex_origin);
    // Vertices were inserted and removed: map each one back to its sample (−1: inserted).
    std::vector<int> source(result->vertex_origin.size(), -1);
    for (std::size_t v = 0; v < source.size(); ++v)
      if (const int o = result->vertex_origin[v]; o >= 0) source[v] = unoptimized_->vertex_source[o];
    mesh_->vertex_source = std::move(source);
    optimization_ = std::move(result);
    if (optimizer_->finished()) optimizer_.reset();  // frees its working mesh
  };
  try {
    while ((k < 0 || done < k) && optimizer_->step(progress)) ++done;
  } catch (const Cancelled&) {
    adopt();
    throw;
  }
  adopt();
  return done;
}

void Pipeline::restart_optimization() {
  if (!unoptimized_) return;  // stage 6 has not started
  optimizer_.reset();
  optimization_.reset();
  mesh_ = std::move(unoptimized_);
  start_optimization();  // again from the kept stage-5 mesh, no pass yet
  done_[int(Stage::mesh)] = false;
  invalidate_from(Stage::evaluate);
}

int Pipeline::step_optimization(int k, const Progress& progress) {
  if (parameters_.optimize != "default")
    throw InputError("optimize: stage 6 is off (optimize = none); set it to default to step it");
  run_through(Stage::shallow, progress);
  if (done_[int(Stage::mesh)]) return 0;  // finished already
  invalidate_from(Stage::evaluate);
  if (!optimizer_) {  // stage 5, and the optimiser set up without running a pass
    first_passes_ = 0;
    try {
      run_stage(Stage::mesh, progress);
    } catch (...) {
      first_passes_ = -1;
      throw;
    }
    first_passes_ = -1;
  }
  const int done = optimizer_ ? optimize_passes(k, progress) : 0;
  done_[int(Stage::mesh)] = !optimizer_;
  return done;
}

int Pipeline::step_lloyd(int k, const Progress& progress) {
  run_through(Stage::surface, progress);
  if (!lloyd_) start_lloyd();
  invalidate_from(Stage::shallow);
  const int done = k < 0 ? lloyd_->run_to_convergence(progress) : lloyd_->run(k, progress);
  done_[int(Stage::cvt)] = lloyd_->converged();
  return done;
}

}  // namespace cvt
