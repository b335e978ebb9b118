// Stage 2 (paper III-C, Algorithm 1): greedy max-energy r-sampling of the boundary voxels F.
// energy(q) = exp(−(h²(q) − r² lfs²(p)) / 2σ²), h(q) = distance to the nearest sample so far,
// p = the sample that last updated q. The sample with the highest energy is taken next; every
// q with d(p, q) < r·lfs(q) is then covered and leaves F. Ends when F is empty, so every
// boundary voxel lies within r·lfs of a sample.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "preprocess/preprocess.h"
#include "base/progress.h"

namespace cvt {

struct SurfaceSamplingOptions {
  double r = 0.4;                   // sampling ratio: samples within r·lfs of every boundary voxel
  // Chord tolerance δ (mm, 0: none): where lfs is large, r·lfs is capped at √(8·δ·lfs), so a
  // chord between two samples on a surface curved with radius ≥ lfs stays within δ of it.
  double chord_tolerance_mm = 0;
  // The surface is sampled as if lfs were at most this (mm; 0: no cap). A segmentation carries
  // detail a voxel or two across (terraces of thick slices, bumps) that the pruned medial axis
  // does not see; without a cap the flattest parts, where lfs is largest, get the longest
  // chords and follow the segmentation worst.
  double surface_lfs_max_mm = 0;
  bool project_to_surface = true;   // move samples onto the 0.5 level of the smoothed indicator
  double max_projection_voxels = 1.5;  // in largest voxel spacings; a projection moving
                                       // farther keeps the voxel centre
};

struct SurfaceSamples {
  std::vector<std::int32_t> voxels;  // sampled boundary voxels (linear index in the object grid)
  std::vector<Vec3> voxel_world;     // their voxel centres (world, mm)
  std::vector<Vec3> world;           // final positions: projected when enabled (world, mm)
  // −(h² − r² lfs²) of each sample when it was taken (mm²): the log of its eq. (3) energy times
  // 2σ². The order of Algorithm 1 depends on it alone, so no sample depends on σ.
  std::vector<float> priority_mm2;
  std::size_t projection_failures = 0;  // samples left at the voxel centre
  double surface_lfs_max_mm = 0;        // the cap of lfs they were taken with (mm; 0: none)
};

// Eq. (3)'s energy of a sample of priority `priority_mm2`, for a σ in mm.
inline double surface_energy(double priority_mm2, double sigma_mm) {
  return std::exp(priority_mm2 / (2.0 * sigma_mm * sigma_mm));
}

SurfaceSamples sample_surface(const PreprocessResult& pre, const SurfaceSamplingOptions& options,
                              const Progress& progress = {});

// The interior spacing that matches the surface samples: their spacing s = r·lfs, weighted by
// the surface area each one covers (∝ c², c its radius: s, or less by the chord cap),
// Σ c² s / Σ c² (mm). Samples crowd where lfs is small, so this matches the bulk of the surface
// rather than its fine parts; and a cap (chord tolerance or lfs cap), which adds samples on
// flat parts, leaves it (an area-weighted mean over the surface) as it was — while the samples
// are sparser than the boundary voxels. Where a radius falls below the voxel, every boundary
// voxel is a sample, c² no longer stands for area and the estimate drops (the skull CT with
// the lfs capped at lfs min: 2.86 → 2.43 mm). 0 without samples.
double area_weighted_spacing_mm(const SurfaceSamples& samples, const Volume<float>& lfs_mm,
                                const SurfaceSamplingOptions& options);

// The median lfs over the object's boundary voxels (mm; 0 without any): the default cap of
// surface_lfs_max_mm, so the flatter half of the surface is sampled as finely as the median
// part, whatever the object's size or the voxel.
double median_boundary_lfs_mm(const PreprocessResult& pre);

// The radius a sample at a voxel of this lfs covers: r·lfs with lfs capped at
// surface_lfs_max_mm (when > 0), and at most √(8·δ·lfs) by a chord tolerance δ > 0 (mm).
inline double sampling_radius_mm(double lfs_mm, const SurfaceSamplingOptions& options) {
  if (options.surface_lfs_max_mm > 0) lfs_mm = std::min(lfs_mm, options.surface_lfs_max_mm);
  const double s = options.r * lfs_mm, delta = options.chord_tolerance_mm;
  return delta > 0 ? std::min(s, std::sqrt(8.0 * delta * lfs_mm)) : s;
}

// Moves a point (continuous index) onto the `level` set of `field` by Newton steps along the
// physical gradient; returns false (and leaves `index`) when it does not converge within
// max_move_voxels × the largest voxel spacing.
bool project_to_level_set(const Volume<float>& field, float level, Vec3& index,
                          double max_move_voxels);

}  // namespace cvt
