#include "parameter_info.h"

namespace cvt::gui {

const std::vector<ParameterInfo>& parameter_infos() {
  using S = Stage;
  static const std::vector<ParameterInfo> infos{
      {"labels", "labels", "Labels that make the object; none ticked = every non-zero label.",
       S::preprocess},
      {"iso", "iso value", "Grey images: threshold (image units); replaces the labels.",
       S::preprocess},
      {"inside_above", "inside ≥ iso", "With an iso value: inside is value ≥ iso (else ≤ iso).",
       S::preprocess},
      {"margin_voxels", "margin (voxels)",
       "Background voxels kept around the object's bounding box when cropping.", S::preprocess},
      {"remove_small_components", "remove specks",
       "Drop connected components smaller than the fraction below.", S::preprocess},
      {"min_component_fraction", "min component",
       "Smallest component kept, as a fraction of the largest (0–1).", S::preprocess},
      {"fill_cavities", "fill cavities", "Enclosed background becomes object.", S::preprocess},
      {"smoothing_sigma_mm", "smoothing σ (mm)",
       "Gaussian σ of the smoothed indicator whose 0.5 level is the sub-voxel boundary (mm); "
       "0 = auto (half the largest spacing).",
       S::preprocess},
      {"medial_min_separation_mm", "medial λ (mm)",
       "Medial axis: least distance between the two nearest boundary points (mm); 0 = auto "
       "(3 × the largest spacing).",
       S::preprocess},
      {"medial_min_angle_deg", "medial θ (°)",
       "Medial axis: least angle between the two nearest boundary points, seen from the voxel "
       "(degrees).",
       S::preprocess},
      {"lfs_min_mm", "lfs min (mm)",
       "Lower clamp of the local feature size (mm); 0 = auto (the "
       "largest spacing).",
       S::preprocess},
      {"lfs_max_mm", "lfs max (mm)",
       "Upper clamp of the local feature size (mm); 0 = auto (10 × the largest spacing).",
       S::preprocess},
      {"r", "r",
       "Surface sampling ratio in (0, 1): every boundary voxel lies within r·lfs of a "
       "sample. Smaller = denser surface.",
       S::surface},
      {"sigma_surface_mm", "σ surface (mm)",
       "σ of the surface sampling energy (eq. 3, mm); scales energies only.", S::surface},
      {"project_samples", "project samples",
       "Move surface samples onto the smoothed indicator's 0.5 level (sub-voxel surface).",
       S::surface},
      {"sigma_density_mm", "σ density (mm)",
       "σ of the interior density ρ = 1 − exp(−lfs²/2σ²) (eq. 4, mm); 0 = auto (the interior "
       "spacing).",
       S::cvt},
      {"interior_spacing_mm", "interior spacing (mm)",
       "Target distance between neighbouring interior points (mm); 0 = auto (the surface "
       "samples' mean spacing).",
       S::cvt},
      {"interior_points", "interior points",
       "Exact number of interior points; wins over the spacing when > 0.", S::cvt},
      {"epsilon_mm", "ε (mm)",
       "Lloyd stops when Σ displacement of the sites < ε (mm); 0 = auto (1 % of the spacing × "
       "the number of sites).",
       S::cvt},
      {"max_iterations", "max iterations", "Cap on Lloyd iterations.", S::cvt},
      {"fidelity_rounds", "fidelity rounds",
       "Stage 5: where the mesh and the segmentation disagree by more than the tolerance (a thin "
       "channel bridged, a thin sheet missed, a narrow pit down to an interior sample), add "
       "surface samples and triangulate again, at most this many times; 0 = off.",
       S::mesh},
      {"fidelity_tolerance_mm", "fidelity tolerance (mm)",
       "Stage 5: disagreement (mm) between mesh and segmentation that triggers a refinement "
       "round; 0 = auto (1.5 × the largest voxel spacing).",
       S::mesh},
      {"optimize", "optimisation",
       "Stage 6, mesh optimisation after generation (part of the mesh stage): default (on) or "
       "none (the paper's stage-5 mesh, slivers and all).",
       S::mesh},
      {"optimization", "stage 6 options",
       "Options of stage 6 (one field each in this section; preset key \"optimization\").",
       S::mesh},
      {"seed", "seed", "Seed of every random choice (initial interior points).", S::cvt},
      {"threads", "threads", "Worker threads for the pipeline; 0 = all cores.", S::count},
      {"max_points", "max points",
       "Guard: refuse runs that would need more interior points than this (a tiny spacing or "
       "r → 0).",
       S::count},
      {"max_memory_mb", "max memory (MB)",
       "Guard: refuse runs whose estimated memory exceeds this (MB); 0 = the available RAM.",
       S::count},
  };
  return infos;
}

const ParameterInfo* find_parameter_info(std::string_view key) {
  for (const ParameterInfo& info : parameter_infos())
    if (info.key == key) return &info;
  return nullptr;
}

}  // namespace cvt::gui
