// Every parameter of every stage, in one flat struct that presets (JSON), the CLI and the viewer
// share. Lengths are in mm. Zero means "auto" where a comment says so.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "optimize/optimization_options.h"

namespace cvt {

struct Parameters {
  // Stage 1: object selection and preprocessing.
  std::vector<std::int64_t> labels;       // object labels; empty = all non-zero
  std::optional<double> iso;              // grey images: threshold (replaces labels)
  bool inside_above = true;               // with iso: inside is value ≥ iso (else ≤)
  int margin_voxels = 4;                  // background kept around the object's box
  bool remove_small_components = true;    // drop specks smaller than the fraction below
  double min_component_fraction = 0.01;   // of the largest component
  bool fill_cavities = true;              // enclosed background becomes object
  double smoothing_sigma_mm = 0;          // smoothed indicator σ; 0 = auto (½ max spacing)
  double medial_min_separation_mm = 0;    // medial-axis λ; 0 = auto (3 × max spacing)
  double medial_min_angle_deg = 120;      // medial-axis θ
  double lfs_min_mm = 0;                  // lfs clamp; 0 = auto (max spacing)
  double lfs_max_mm = 0;                  // lfs clamp; 0 = auto (10 × max spacing)
  // Stage 2: surface sampling.
  double r = 0.4;                         // r-sampling ratio, in (0, 1)
  double sigma_surface_mm = 2.0;          // σ of the surface energy (eq. 3)
  bool project_samples = true;            // samples onto the sub-voxel boundary surface
  // Stage 3: CVT interior sampling.
  double sigma_density_mm = 0;            // σ of the density (eq. 4); 0 = auto
  double interior_spacing_mm = 0;         // target spacing of interior points; 0 = auto
  std::int64_t interior_points = 0;       // exact count of interior points (wins if > 0)
  double epsilon_mm = 0;                  // stop when Σ displacement < ε; 0 = auto
  int max_iterations = 50;                // Lloyd iteration cap
  // Stage 5: mesh generation, refined where mesh and segmentation disagree.
  int fidelity_rounds = 3;                // re-triangulations with added surface samples; 0 = off
  double fidelity_tolerance_mm = 0;       // disagreement that triggers one; 0 = auto (1.5 × max
                                          // spacing)
  // Stage 6: optimisation.
  std::string optimize = "default";       // "default" | "none" (stage 5 as the paper has it)
  OptimizationOptions optimization;       // its options (preset: "optimization": {...})
  // Everywhere.
  std::uint64_t seed = 1;                 // every random choice is seeded from this
  int threads = 0;                        // worker threads; 0 = all cores
  // Guards against parameters that would explode (r → 0, a tiny spacing) or not fit.
  std::int64_t max_points = 5000000;      // refuse runs needing more interior points than this
  double max_memory_mb = 0;               // refuse runs estimated above this; 0 = available RAM

  bool operator==(const Parameters&) const = default;
};

// Throws InputError naming the offending key when a value is out of range.
void validate(const Parameters& parameters);

}  // namespace cvt
