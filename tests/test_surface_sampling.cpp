// Stage 2: greedy r-sampling of the boundary voxels (Algorithm 1) on analytic phantoms.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "base/errors.h"
#include "phantoms.h"
#include "sampling/surface_sampling.h"

using namespace cvt;

namespace {

PreprocessResult preprocess_phantom(const Phantom& p, const Vec3& spacing,
                                    const std::array<double, 9>& direction) {
  PreprocessOptions opt;
  opt.lfs.max_mm = 100;
  return preprocess(rasterize(p, grid_around(p, spacing, direction)), opt);
}

// Largest ratio d(voxel, nearest sample voxel) / (its sampling radius, r · lfs(voxel) or less
// by a chord tolerance) over all boundary voxels.
double worst_coverage_ratio(const PreprocessResult& pre, const SurfaceSamples& s,
                            const SurfaceSamplingOptions& opt) {
  const Grid& g = pre.object.grid;
  double worst = 0;
  for (std::int32_t f : pre.boundary) {
    const Vec3 x = g.voxel_to_world(std::size_t(f));
    double best = 1e300;
    for (const Vec3& b : s.voxel_world) best = std::min(best, squared_distance(x, b));
    worst = std::max(worst, std::sqrt(best) / sampling_radius_mm(pre.lfs_mm.data[f], opt));
  }
  return worst;
}

// A sphere (lfs = R everywhere) in voxels of 0.5 × 0.5 × 0.6 mm.
PreprocessResult sphere_of_radius(double R) {
  return preprocess_phantom(sphere_phantom({0, 0, 0}, R), {0.5, 0.5, 0.6},
                            rotation_matrix({0, 0, 1}, 0));
}

}  // namespace

TEST(SurfaceSampling, EveryBoundaryVoxelIsRSampled) {
  const Phantom p = torus_phantom({5, 6, 7}, 10.0, 4.0);
  const PreprocessResult pre = preprocess_phantom(p, {0.7, 0.8, 1.1}, rotation_matrix({1, 2, 0}, 0.6));
  for (double r : {0.3, 0.6}) {
    SurfaceSamplingOptions opt;
    opt.r = r;
    const SurfaceSamples s = sample_surface(pre, opt);
    ASSERT_GT(s.voxels.size(), 10u);
    EXPECT_LT(worst_coverage_ratio(pre, s, opt), 1.0) << "r = " << r;
    // Samples are distinct boundary voxels.
    std::vector<std::int32_t> sorted = s.voxels;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
    for (std::int32_t v : s.voxels)
      EXPECT_TRUE(std::binary_search(pre.boundary.begin(), pre.boundary.end(), v));
  }
}

TEST(SurfaceSampling, CountGrowsQuadraticallyWhenRHalves) {
  // On a sphere (lfs = R everywhere) samples are ≈ r·R apart, so the count ∝ 1/r².
  const Phantom p = sphere_phantom({0, 0, 0}, 15.0);
  const PreprocessResult pre = preprocess_phantom(p, {0.5, 0.5, 0.6}, rotation_matrix({0, 0, 1}, 0));
  SurfaceSamplingOptions opt;
  opt.r = 0.4;
  const double coarse = double(sample_surface(pre, opt).voxels.size());
  opt.r = 0.2;
  const double fine = double(sample_surface(pre, opt).voxels.size());
  EXPECT_GT(fine / coarse, 3.0);
  EXPECT_LT(fine / coarse, 5.0);
}

TEST(SurfaceSampling, ProjectedSamplesLieOnTheSphere) {
  const double R = 10.0;
  const Phantom p = sphere_phantom({1, 2, 3}, R);
  const Vec3 spacing{0.6, 0.7, 1.0};
  const PreprocessResult pre = preprocess_phantom(p, spacing, rotation_matrix({1, 1, 0}, 0.4));
  SurfaceSamplingOptions opt;
  opt.r = 0.3;
  const SurfaceSamples s = sample_surface(pre, opt);
  ASSERT_EQ(s.world.size(), s.voxels.size());
  EXPECT_EQ(s.projection_failures, 0u);
  std::vector<double> err, voxel_err;
  for (std::size_t i = 0; i < s.world.size(); ++i) {
    err.push_back(std::abs(distance(s.world[i], p.center) - R));
    voxel_err.push_back(std::abs(distance(s.voxel_world[i], p.center) - R));
  }
  std::sort(err.begin(), err.end());
  std::sort(voxel_err.begin(), voxel_err.end());
  const double min_spacing = 0.6, max_spacing = 1.0;
  // Voxel centres sit up to a voxel inside; projected samples within a fraction of one. On a
  // flat cap of the voxelised sphere the mask cannot say where within the last voxel the
  // surface is, so the worst case stays half a voxel along the coarsest axis.
  EXPECT_LT(err[err.size() / 2], 0.15 * min_spacing) << "voxel centres: " << voxel_err[voxel_err.size() / 2];
  EXPECT_LT(err[err.size() * 95 / 100], 0.35 * min_spacing);
  EXPECT_LE(err.back(), 0.5 * max_spacing + 1e-3);
  EXPECT_LT(err[err.size() / 2], 0.3 * voxel_err[voxel_err.size() / 2]);
}

TEST(SurfaceSampling, DeterministicAndRejectsBadParameters) {
  const Phantom p = two_spheres_phantom({0, 0, 0}, 6.0, 0.0);
  const PreprocessResult pre = preprocess_phantom(p, {0.8, 0.8, 0.8}, rotation_matrix({0, 0, 1}, 0));
  const SurfaceSamples a = sample_surface(pre, SurfaceSamplingOptions{});
  const SurfaceSamples b = sample_surface(pre, SurfaceSamplingOptions{});
  EXPECT_EQ(a.voxels, b.voxels);
  SurfaceSamplingOptions bad;
  bad.r = 0;
  EXPECT_THROW(sample_surface(pre, bad), InputError);
  // One priority per sample (eq. (3)'s energy on a log scale), the same in both runs.
  ASSERT_EQ(a.priority_mm2.size(), a.voxels.size());
  EXPECT_EQ(a.priority_mm2, b.priority_mm2);
  for (float k : a.priority_mm2) EXPECT_TRUE(std::isfinite(surface_energy(k, 2.0)));
}

namespace {

// On a sphere of radius R (lfs = R), sampled with r = 0.4: a cap gives between min_ratio and
// max_ratio × the samples without it, every boundary voxel within the capped radius of one; a
// loose cap changes nothing; and the interior spacing that matches the surface (an
// area-weighted mean of r·lfs) stays r·R.
void expect_cap_on_sphere(double R, const SurfaceSamplingOptions& capped,
                          const SurfaceSamplingOptions& loose, double min_ratio,
                          double max_ratio) {
  const PreprocessResult pre = sphere_of_radius(R);
  SurfaceSamplingOptions plain;
  plain.r = 0.4;
  const SurfaceSamples a = sample_surface(pre, plain), b = sample_surface(pre, capped);
  const double ratio = double(b.voxels.size()) / double(a.voxels.size());
  EXPECT_GT(ratio, min_ratio);
  EXPECT_LT(ratio, max_ratio);
  EXPECT_LT(worst_coverage_ratio(pre, b, capped), 1.0);
  EXPECT_EQ(sample_surface(pre, loose).voxels, a.voxels);
  EXPECT_NEAR(area_weighted_spacing_mm(b, pre.lfs_mm, capped),
              area_weighted_spacing_mm(a, pre.lfs_mm, plain), 0.03 * 0.4 * R);
}

}  // namespace

// r·R = 6 mm apart without a chord tolerance; with δ = 0.1 mm the radius is √(8·δ·R) =
// 3.46 mm, so ≈ (6 / 3.46)² = 3× the samples; a δ at least r²·R/8 caps nothing.
TEST(SurfaceSampling, ChordToleranceCapsTheRadiusWhereLfsIsLarge) {
  const double R = 15.0;
  SurfaceSamplingOptions capped, loose;
  capped.r = loose.r = 0.4;
  capped.chord_tolerance_mm = 0.1;
  loose.chord_tolerance_mm = 0.4 * 0.4 * 20.0 / 8.0;  // above r²·lfs/8 for every lfs ≤ 20
  EXPECT_LT(sampling_radius_mm(R, capped), 0.6 * 0.4 * R);
  expect_cap_on_sphere(R, capped, loose, 2.2, 4.0);
}

// The lfs cap at R/2: the radius is r·R/2, so ≈ 4× the samples; a cap at or above every lfs
// changes nothing; the samples record their cap.
TEST(SurfaceSampling, LfsCapSamplesFlatPartsAsFinelyAsTheCap) {
  const double R = 15.0;
  SurfaceSamplingOptions capped, loose;
  capped.r = loose.r = 0.4;
  capped.surface_lfs_max_mm = R / 2;
  loose.surface_lfs_max_mm = 20.0;  // above every lfs of the sphere (≤ its radius)
  EXPECT_DOUBLE_EQ(sampling_radius_mm(R, capped), 0.4 * R / 2);
  EXPECT_EQ(sample_surface(sphere_of_radius(R), capped).surface_lfs_max_mm, R / 2);
  expect_cap_on_sphere(R, capped, loose, 3.0, 5.5);
}
