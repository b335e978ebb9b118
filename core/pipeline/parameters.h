// Every parameter of every stage, as the stages read them. Each one's key, unit, range, stage,
// label and meaning are in the parameter registry (parameter_registry.cpp), from which presets,
// the CLI, the viewer's panel, validation and stale-stage tracking are derived: a new parameter
// is a member here, a row there, and its use. Lengths are in mm; 0 means "auto" where the
// registry says so.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "base/nifti_frames.h"
#include "optimize/optimization_options.h"

namespace cvt {

// Stage 6 on or off ("none": the paper's stage-5 mesh, as it is).
enum class OptimizeMode { none, standard };

struct Parameters {
  // Reading the image (its geometry, so everything from stage 1 on).
  NiftiFrame nifti_frame = NiftiFrame::sform;
  // Stage 1: object selection and preprocessing.
  std::vector<std::int64_t> labels;  // empty = all non-zero
  std::optional<double> iso;         // grey images: threshold (replaces labels)
  bool inside_above = true;
  int margin_voxels = 4;
  bool remove_small_components = true;
  double min_component_fraction = 0.01;
  bool fill_cavities = true;
  double max_cavity_fraction = 0.01;
  double smoothing_sigma_mm = 0;
  double medial_min_separation_mm = 0;
  double medial_min_angle_deg = 120;
  double lfs_min_mm = 0;
  double lfs_max_mm = 0;
  // Stage 2: surface sampling.
  double r = 0.4;
  double chord_tolerance_mm = 0;
  double surface_lfs_max_mm = 0;  // 0: auto (median boundary lfs)
  std::int64_t target_vertices = 0;  // --vertices: r and the interior points scaled to reach it
  double sigma_surface_mm = 2.0;
  bool project_samples = true;
  // Stage 3: CVT interior sampling.
  double sigma_density_mm = 0;
  double interior_spacing_mm = 0;
  std::int64_t interior_points = 0;
  double epsilon_mm = 0;
  int max_iterations = 50;
  std::uint64_t seed = 1;
  bool lattice_start = true;  // initial interior points on a lattice (else drawn from ρ)
  // Stage 5: mesh generation, refined where mesh and segmentation disagree.
  int fidelity_rounds = 3;
  double fidelity_tolerance_mm = 0;
  // Stage 6: optimisation.
  OptimizeMode optimize = OptimizeMode::standard;
  OptimizationOptions optimization;
  // No stage: how the run is carried out, not what it makes.
  int threads = 0;
  std::int64_t max_points = 5000000;
  double max_memory_mb = 0;

  bool operator==(const Parameters&) const = default;
};

}  // namespace cvt
