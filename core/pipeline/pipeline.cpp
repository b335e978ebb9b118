#include "pipeline/pipeline.h"

#include <tbb/parallel_invoke.h>

#include <chrono>

#include "base/errors.h"
#include "pipeline/parameter_registry.h"
#include "base/memory.h"
#include "pipeline/vertex_budget.h"

namespace cvt {

ReadOptions image_read_options(const Parameters& p) {
  ReadOptions o;
  o.nifti_frame = p.nifti_frame;
  return o;
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
  o.cleanup.max_cavity_fraction = p.max_cavity_fraction;
  o.smoothing_sigma_mm = p.smoothing_sigma_mm;
  o.medial_axis.min_separation_mm = p.medial_min_separation_mm;
  o.medial_axis.min_angle_deg = p.medial_min_angle_deg;
  o.lfs.min_mm = p.lfs_min_mm;
  o.lfs.max_mm = p.lfs_max_mm;
  o.max_bytes = std::size_t(p.max_memory_mb * 1024.0 * 1024.0);
  return o;
}

SurfaceSamplingOptions surface_options(const Parameters& p, const PreprocessResult& pre) {
  SurfaceSamplingOptions o;
  o.r = p.r;
  o.chord_tolerance_mm = p.chord_tolerance_mm;
  o.surface_lfs_max_mm =
      p.surface_lfs_max_mm > 0 ? p.surface_lfs_max_mm : median_boundary_lfs_mm(pre);
  o.project_to_surface = p.project_samples;
  return o;
}

namespace {

bool capped(const SurfaceSamplingOptions& options) {
  return options.surface_lfs_max_mm > 0 || options.chord_tolerance_mm > 0;
}

// The area-weighted spacing of the samples `options` would give without their cap.
double uncapped_spacing_mm(const PreprocessResult& pre, const SurfaceSamplingOptions& options) {
  SurfaceSamplingOptions plain = options;
  plain.surface_lfs_max_mm = plain.chord_tolerance_mm = 0;
  plain.project_to_surface = false;  // the count is what matters
  return area_weighted_spacing_mm(sample_surface(pre, plain), pre.lfs_mm, plain);
}

}  // namespace

SampledSurface sample_surface_and_spacing(const PreprocessResult& pre,
                                          const SurfaceSamplingOptions& options,
                                          const Progress& progress) {
  SampledSurface out;
  double uncapped = 0;
  tbb::parallel_invoke([&] { out.samples = sample_surface(pre, options, progress); },
                       [&] { if (capped(options)) uncapped = uncapped_spacing_mm(pre, options); });
  if (!out.samples.voxels.empty())
    out.interior_spacing_mm = capped(options)
                                  ? uncapped
                                  : area_weighted_spacing_mm(out.samples, pre.lfs_mm, options);
  return out;
}

CvtOptions cvt_options(const Parameters& p, double default_spacing_mm) {
  CvtOptions o;
  o.sigma_density_mm = p.sigma_density_mm;
  o.interior_spacing_mm = p.interior_spacing_mm > 0 ? p.interior_spacing_mm : default_spacing_mm;
  o.interior_points = p.interior_points;
  o.epsilon_mm = p.epsilon_mm;
  o.max_iterations = p.max_iterations;
  o.seed = p.seed;
  o.lattice_start = p.lattice_start;
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

void Pipeline::set_image(std::shared_ptr<const Image> image, Run run) {
  image_ = std::move(image);
  run_ = run;
  invalidate_from(Stage::preprocess);
}

void Pipeline::set_parameters(const Parameters& parameters) {
  validate(parameters);
  const Stage changed = first_changed_stage(parameters_, parameters);
  parameters_ = parameters;
  if (changed != Stage::count) invalidate_from(changed);
}

void Pipeline::set_evaluate_fidelity(bool on) {
  if (on == evaluate_fidelity_) return;
  evaluate_fidelity_ = on;
  if (on && !fidelity_) invalidate_from(Stage::evaluate);
  if (!on && fidelity_) {
    fidelity_.reset();
    ++generation_[int(Stage::evaluate)];
  }
}

void Pipeline::invalidate_from(Stage s) {
  for (int i = int(s); i < kStageCount; ++i) {
    done_[i] = false;
    ++generation_[i];
  }
  switch (s) {  // drop results that no longer match (each case falls through downstream)
    case Stage::preprocess: preprocess_.reset(); [[fallthrough]];
    case Stage::surface:
      surface_.reset();
      budget_r_ = 0;
      interior_spacing_mm_ = 0;
      [[fallthrough]];
    case Stage::cvt:
      lloyd_.reset();
      budget_points_ = 0;
      [[fallthrough]];
    case Stage::shallow: shallow_.reset(); [[fallthrough]];
    case Stage::mesh: mesh_.reset(); [[fallthrough]];
    case Stage::optimize:
      optimizer_.reset();
      optimized_.reset();
      [[fallthrough]];
    case Stage::evaluate:
      quality_.reset();
      fidelity_.reset();
      [[fallthrough]];
    case Stage::count: break;
  }
}

const TetMesh* Pipeline::final_mesh() const {
  if (optimized_) return &optimized_->mesh;
  return mesh_ ? &mesh_->mesh : nullptr;
}

Parameters Pipeline::sized_parameters() const {
  Parameters p = parameters_;
  if (budget_r_ > 0) p.r = budget_r_;
  if (budget_points_ > 0) p.interior_points = budget_points_;
  return p;
}

double Pipeline::budget_r() const {
  // The samples the user's r gives (their count only: no projection), and the interior sites
  // that match them.
  SurfaceSamplingOptions probe = surface_options(parameters_, *preprocess_);
  probe.project_to_surface = false;
  const auto [s, spacing] = sample_surface_and_spacing(*preprocess_, probe);
  Parameters p = parameters_;
  p.interior_points = 0;
  const CvtResolved r = resolve_cvt_options(cvt_options(p, spacing), preprocess_->object);
  return r_for_budget(parameters_.r, std::int64_t(s.voxels.size()), r.sites,
                      parameters_.target_vertices);
}

void Pipeline::start_lloyd() {
  const std::int64_t target = parameters_.target_vertices;
  if (target > 0 && budget_points_ == 0) {
    // The shallow share at a first guess (the sites as first drawn), then the count that
    // leaves the budget's interior vertices.
    const std::int64_t surface = std::int64_t(surface_->voxels.size());
    Parameters p = parameters_;
    p.interior_points = std::max<std::int64_t>(1, target - surface);
    LloydStepper probe(*preprocess_, cvt_options(p, default_interior_spacing_mm()));
    probe.initialize();
    const std::size_t shallow =
        remove_shallow_points(probe.sites_world(), probe.owners_of(preprocess_->boundary))
            .removed_index.size();
    budget_points_ = interior_points_for_budget(target, surface, p.interior_points,
                                                double(shallow) / double(p.interior_points));
  }
  const CvtOptions options = cvt_options(sized_parameters(), default_interior_spacing_mm());
  const CvtResolved r = resolve_cvt_options(options, preprocess_->object);
  if (r.sites > parameters_.max_points)
    throw InputError("interior points: " + std::to_string(r.sites) + " needed (spacing " +
                     std::to_string(r.spacing_mm) + " mm) exceed max_points = " +
                     std::to_string(parameters_.max_points) +
                     "; raise --interior-spacing or --max-points");
  lloyd_ = std::make_unique<LloydStepper>(*preprocess_, options);
  lloyd_->initialize();
}

void Pipeline::record(std::string name, double wall_s) {
  records_.push_back({std::move(name), wall_s, double(peak_rss_bytes()) / (1024.0 * 1024.0)});
}

void Pipeline::run_stage(Stage s, const Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  switch (s) {
    case Stage::preprocess:
      if (!image_) throw InputError("no image loaded");
      break;
    case Stage::surface:
    case Stage::cvt:
    case Stage::mesh: {
      const bool freed = s == Stage::mesh ? preprocess_->nearest_opposite.data.empty()
                                          : preprocess_->lfs_mm.data.empty();
      if (freed)
        throw InputError(std::string(stage_name(s)) +
                         ": this single run has freed its inputs; load the image again");
      break;
    }
    default: break;
  }
  switch (s) {
    case Stage::preprocess:
      preprocess_ = std::make_shared<PreprocessResult>(cvt::preprocess(
          run_ == Run::once ? std::move(image_) : image_,
          preprocess_options(parameters_), progress));
      break;
    case Stage::surface: {
      if (parameters_.target_vertices > 0) budget_r_ = budget_r();
      const SurfaceSamplingOptions options = surface_options(sized_parameters(), *preprocess_);
      SampledSurface sampled = sample_surface_and_spacing(*preprocess_, options, progress);
      surface_ = std::make_unique<SurfaceSamples>(std::move(sampled.samples));
      interior_spacing_mm_ = sampled.interior_spacing_mm;
      break;
    }
    case Stage::cvt:
      if (!lloyd_) start_lloyd();
      run_lloyd(-1, progress);
      break;
    case Stage::shallow:
      shallow_ = std::make_unique<ShallowResult>(remove_shallow_points(
          lloyd_->sites_world(), lloyd_->owners_of(preprocess_->boundary)));
      break;
    case Stage::mesh:
      mesh_ = std::make_unique<RefinedMesh>(
          build_refined_mesh(*preprocess_, surface_->world, shallow_->kept_world,
                             mesh_options(parameters_), refinement_options(parameters_), progress));
      break;
    case Stage::optimize:
      if (parameters_.optimize == OptimizeMode::none) {  // off: stage 5's mesh is the result
        done_[int(s)] = true;
        return;
      }
      optimize_passes(-1, progress);
      break;
    case Stage::evaluate:
      evaluate(progress);  // records its two parts itself
      done_[int(s)] = true;
      ++generation_[int(s)];
      return;
    case Stage::count: break;
  }
  done_[int(s)] = true;
  ++generation_[int(s)];
  if (run_ == Run::once) free_inputs_used_up_by(s);
  record(std::string(stage_name(s)),
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void Pipeline::free_inputs_used_up_by(Stage s) {
  const auto drop = [](auto& volume) { volume = std::decay_t<decltype(volume)>(); };
  switch (s) {
    case Stage::preprocess: drop(preprocess_->medial_axis); break;  // the lfs is made of it
    case Stage::cvt: drop(preprocess_->lfs_mm); break;  // the bricks hold the density
    case Stage::shallow: lloyd_->release_voxels(); break;  // sites and history stay
    case Stage::mesh: drop(preprocess_->nearest_opposite); break;  // refinement's last use
    default: break;
  }
}

void Pipeline::evaluate(const Progress& progress) {
  // Two records, so element quality and the (slower) fidelity are timed apart.
  const TetMesh& mesh = *final_mesh();
  auto t0 = std::chrono::steady_clock::now();
  progress(std::string(kQualityRecord), 0.0);
  quality_ = std::make_unique<QualityReport>(compute_quality(mesh));
  record(std::string(kQualityRecord),
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  if (!evaluate_fidelity_) return;
  progress(std::string(kFidelityRecord), 0.5);
  t0 = std::chrono::steady_clock::now();
  fidelity_ = std::make_unique<FidelityReport>(
      compute_fidelity(mesh, preprocess_->object, {}, progress));
  record(std::string(kFidelityRecord),
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void Pipeline::run_through(Stage last, const Progress& progress) {
  for (int s = 0; s <= int(last); ++s)
    if (!done_[s]) run_stage(Stage(s), progress);
}

int Pipeline::optimize_passes(int k, const Progress& progress) {
  progress(std::string(stage_name(Stage::optimize)), 0.0);
  if (!optimizer_) {
    OptimizationOptions options = parameters_.optimization;  // auto sizes from stage 1's scale
    if (options.boundary_tolerance_mm == 0)
      options.boundary_tolerance_mm = auto_boundary_tolerance_mm(preprocess_->sizing_unit_mm);
    optimizer_ = std::make_unique<MeshOptimizer>(mesh_->mesh, &preprocess_->indicator, options,
                                                 pass_statistics_, &preprocess_->object);
  }
  int done = 0;
  // The mesh follows the optimiser also after a cancel (every phase of a pass keeps it valid).
  auto adopt = [&] {
    auto result = std::make_unique<OptimizedMesh>();
    result->optimization = optimizer_->result();
    result->mesh = optimizer_->mesh(&result->optimization.vertex_origin);
    // Vertices were inserted and removed: map each one back to its sample (−1: inserted).
    const std::vector<std::int32_t>& origin = result->optimization.vertex_origin;
    result->vertex_source.assign(origin.size(), -1);
    for (std::size_t v = 0; v < origin.size(); ++v)
      if (origin[v] >= 0) result->vertex_source[v] = mesh_->vertex_source[std::size_t(origin[v])];
    optimized_ = std::move(result);
    ++generation_[int(Stage::optimize)];
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

int Pipeline::step_optimization(int k, const Progress& progress) {
  if (parameters_.optimize != OptimizeMode::standard)
    throw InputError("optimize: stage 6 is off (optimize = " +
                     std::string(optimize_word(parameters_.optimize)) + "); set it to " +
                     std::string(optimize_word(OptimizeMode::standard)) + " to step it");
  run_through(Stage::mesh, progress);
  if (done_[int(Stage::optimize)]) return 0;  // finished already
  invalidate_from(Stage::evaluate);
  const auto t0 = std::chrono::steady_clock::now();
  const int done = optimize_passes(k, progress);
  record(std::string(kOptimizationPassesRecord),
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  done_[int(Stage::optimize)] = !optimizer_;
  return done;
}

int Pipeline::step_lloyd(int k, const Progress& progress) {
  run_through(Stage::surface, progress);
  if (!lloyd_) start_lloyd();
  invalidate_from(Stage::shallow);
  const int done = run_lloyd(k, progress);
  done_[int(Stage::cvt)] = lloyd_->converged();
  return done;
}

int Pipeline::run_lloyd(int k, const Progress& progress) {
  try {
    const int done = k < 0 ? lloyd_->run_to_convergence(progress) : lloyd_->run(k, progress);
    ++generation_[int(Stage::cvt)];
    return done;
  } catch (const Cancelled&) {
    ++generation_[int(Stage::cvt)];  // the sites moved as far as the cancel let them
    throw;
  }
}

}  // namespace cvt
