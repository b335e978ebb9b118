#include "parameter_options.h"

#include <algorithm>
#include <string>

#include "base/errors.h"
#include "preprocess/object_selection.h"
#include "pipeline/preset.h"

namespace cvt::cli {

ParameterOptions::ParameterOptions(CLI::App* cmd, Scope scope) {
  // Each bound option copies its parsed value into the resolved parameters only when given.
  auto bind = [&](CLI::Option* opt, auto member) {
    bindings_.push_back({opt, [this, member](Parameters& p) { p.*member = given_.*member; }});
  };
  cmd->add_option("--preset", preset_path_, "Parameter preset (JSON) to start from");
  bindings_.push_back({cmd->add_option("--labels", labels_text_, "Object labels: all | L1,L2,..."),
                       [this](Parameters& p) { p.labels = parse_label_list(labels_text_); }});
  bindings_.push_back({cmd->add_option("--iso", iso_, "Grey images: threshold value of the object"),
                       [this](Parameters& p) { p.iso = iso_; }});
  bindings_.push_back(
      {cmd->add_option("--inside", inside_text_, "With --iso: inside is above or below it")
           ->check(CLI::IsMember({"above", "below"})),
       [this](Parameters& p) { p.inside_above = inside_text_ == "above"; }});
  bind(cmd->add_option("--margin", given_.margin_voxels, "Background voxels kept around the object"),
       &Parameters::margin_voxels);
  bind(cmd->add_option("--fill-cavities", given_.fill_cavities, "Fill enclosed background (true/false)"),
       &Parameters::fill_cavities);
  bind(cmd->add_option("--remove-small-components", given_.remove_small_components,
                       "Drop small object components (true/false)"),
       &Parameters::remove_small_components);
  bind(cmd->add_option("--min-component-fraction", given_.min_component_fraction,
                       "Components smaller than this fraction of the largest are dropped"),
       &Parameters::min_component_fraction);
  if (scope == Scope::object) return;
  bind(cmd->add_option("--smoothing-sigma", given_.smoothing_sigma_mm,
                       "σ (mm) of the smoothed indicator; 0 = auto"),
       &Parameters::smoothing_sigma_mm);
  bind(cmd->add_option("--medial-separation", given_.medial_min_separation_mm,
                       "Medial-axis filter λ (mm); 0 = auto"),
       &Parameters::medial_min_separation_mm);
  bind(cmd->add_option("--medial-angle", given_.medial_min_angle_deg,
                       "Medial-axis filter θ (degrees)"),
       &Parameters::medial_min_angle_deg);
  bind(cmd->add_option("--lfs-min", given_.lfs_min_mm, "Lower lfs clamp (mm); 0 = auto"),
       &Parameters::lfs_min_mm);
  bind(cmd->add_option("--lfs-max", given_.lfs_max_mm, "Upper lfs clamp (mm); 0 = auto"),
       &Parameters::lfs_max_mm);
  bind(cmd->add_option("--r", given_.r, "Surface r-sampling ratio in (0,1)"), &Parameters::r);
  bind(cmd->add_option("--sigma-surface", given_.sigma_surface_mm, "σ (mm) of the surface energy"),
       &Parameters::sigma_surface_mm);
  bind(cmd->add_option("--project-samples", given_.project_samples,
                       "Move surface samples onto the sub-voxel surface (true/false)"),
       &Parameters::project_samples);
  bind(cmd->add_option("--sigma-density", given_.sigma_density_mm,
                       "σ (mm) of the CVT density; 0 = auto"),
       &Parameters::sigma_density_mm);
  auto* spacing = cmd->add_option("--interior-spacing", given_.interior_spacing_mm,
                                  "Interior point spacing (mm); 0 = from the surface samples");
  auto* points = cmd->add_option("--interior-points", given_.interior_points,
                                 "Number of interior points (wins over the spacing)");
  spacing->excludes(points);
  bind(spacing, &Parameters::interior_spacing_mm);
  bind(points, &Parameters::interior_points);
  bind(cmd->add_option("--epsilon", given_.epsilon_mm,
                       "Stop Lloyd when Σ displacement (mm) is below this; 0 = auto"),
       &Parameters::epsilon_mm);
  bind(cmd->add_option("--max-iterations", given_.max_iterations, "Lloyd iteration cap"),
       &Parameters::max_iterations);
  bind(cmd->add_option("--fidelity-rounds", given_.fidelity_rounds,
                       "Re-triangulations adding surface samples where mesh and segmentation "
                       "disagree; 0 = off"),
       &Parameters::fidelity_rounds);
  bind(cmd->add_option("--fidelity-tolerance", given_.fidelity_tolerance_mm,
                       "Disagreement (mm) that triggers a re-triangulation; 0 = auto"),
       &Parameters::fidelity_tolerance_mm);
  bind(cmd->add_option("--optimize", given_.optimize, "Mesh optimisation (stage 6): default | none (the paper's stage-5 mesh)")
           ->check(CLI::IsMember({"none", "default"})),
       &Parameters::optimize);
  // Stage 6: --opt-KEY for every option of the table (the preset's "optimization" keys).
  for (const OptimizationField& f : optimization_fields()) {
    std::string name = "--opt-" + std::string(f.key);
    std::replace(name.begin(), name.end(), '_', '-');
    const std::string help = std::string(f.tooltip) + " (with --optimize default)";
    CLI::Option* opt = nullptr;
    visit_field(f, given_.optimization,
                [&](auto& member) { opt = cmd->add_option(name, member, help); });
    opt->group("Stage 6 (optimisation)");
    bindings_.push_back({opt, [this, f](Parameters& p) {
                           copy_field(f, given_.optimization, p.optimization);
                         }});
  }
  bind(cmd->add_option("--seed", given_.seed, "Seed of every random choice"), &Parameters::seed);
  bind(cmd->add_option("--threads", given_.threads, "Worker threads; 0 = all cores"),
       &Parameters::threads);
  bind(cmd->add_option("--max-points", given_.max_points,
                       "Refuse runs needing more interior points than this"),
       &Parameters::max_points);
  bind(cmd->add_option("--max-memory", given_.max_memory_mb,
                       "Refuse runs estimated to need more memory (MB); 0 = available"),
       &Parameters::max_memory_mb);
}

Parameters ParameterOptions::resolve() const {
  Parameters p = preset_path_.empty() ? Parameters{} : load_preset(preset_path_);
  for (const auto& [opt, apply] : bindings_)
    if (opt->count() > 0) apply(p);
  try {
    validate(p);
  } catch (const InputError& e) {
    throw InputError(std::string("parameter ") + e.what());
  }
  return p;
}

}  // namespace cvt::cli
