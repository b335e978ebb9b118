#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "base/errors.h"
#include "fields/distance_transform.h"

using cvt::FeatureTransform;
using cvt::Grid;
using cvt::Mask;
using cvt::Vec3;

namespace {

Mask random_mask(const std::array<int, 3>& dims, const Vec3& spacing, double density,
                 unsigned seed) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  g.origin = {-3.5, 12.0, 40.25};  // irrelevant to distances, but not trivial
  Mask m(g);
  std::mt19937 rng(seed);
  std::bernoulli_distribution feature(density);
  for (auto& v : m.data) v = feature(rng) ? 1 : 0;
  return m;
}

Vec3 index_of(const Grid& g, std::size_t v) {
  const auto ijk = g.ijk(v);
  return {double(ijk[0]), double(ijk[1]), double(ijk[2])};
}

// Squared distance (mm²) between two voxels, in double.
double squared_distance(const Grid& g, std::size_t a, std::size_t b) {
  const auto p = g.ijk(a), q = g.ijk(b);
  const double dx = (p[0] - q[0]) * g.spacing.x, dy = (p[1] - q[1]) * g.spacing.y,
               dz = (p[2] - q[2]) * g.spacing.z;
  return dx * dx + dy * dy + dz * dz;
}

// Float results carry a few roundings of the stored intermediate values.
double tolerance(double expected) {
  return 2e-6 * expected + 1e-9;
}

// Checks every `check_every`-th voxel against the O(N·F) minimum over all features, and that
// the distance-only transform gives bitwise the feature transform's distances everywhere.
void expect_matches_brute_force(const Mask& m, std::size_t check_every = 1) {
  const Grid& g = m.grid;
  std::vector<Vec3> feature_mm;  // feature positions in the local frame, for a fast inner loop
  for (std::size_t v = 0; v < m.size(); ++v)
    if (m.data[v]) feature_mm.push_back(g.index_to_local(index_of(g, v)));

  const FeatureTransform ft = cvt::compute_feature_transform(m);
  const FeatureTransform ft_no_nearest = cvt::compute_feature_transform(m, false);
  ASSERT_EQ(ft.squared_distance_mm2.size(), m.size());
  ASSERT_EQ(ft.nearest.size(), m.size());
  ASSERT_TRUE(ft_no_nearest.nearest.data.empty());
  ASSERT_EQ(ft_no_nearest.squared_distance_mm2.size(), m.size());
  EXPECT_EQ(std::memcmp(ft.squared_distance_mm2.data.data(),
                        ft_no_nearest.squared_distance_mm2.data.data(), m.size() * sizeof(float)),
            0)
      << "the distance-only transform differs from the feature transform's distances";

  int failures = 0;
  for (std::size_t v = 0; v < m.size() && failures < 10; v += check_every) {
    const float got = ft.squared_distance_mm2.data[v];
    const std::int32_t nearest = ft.nearest.data[v];
    if (feature_mm.empty()) {
      failures += !(std::isinf(got) && nearest == -1);
      EXPECT_TRUE(std::isinf(got)) << "voxel " << v;
      EXPECT_EQ(nearest, -1) << "voxel " << v;
      continue;
    }
    const Vec3 p = g.index_to_local(index_of(g, v));
    double expected = std::numeric_limits<double>::infinity();
    for (const Vec3& f : feature_mm) {
      const double dx = p.x - f.x, dy = p.y - f.y, dz = p.z - f.z;
      const double d2 = dx * dx + dy * dy + dz * dz;
      expected = d2 < expected ? d2 : expected;
    }
    const bool distance_ok = std::abs(got - expected) <= tolerance(expected);
    const bool nearest_ok =
        nearest >= 0 && std::size_t(nearest) < m.size() && m.data[nearest] &&
        std::abs(squared_distance(g, v, nearest) - expected) <= tolerance(expected);
    failures += !(distance_ok && nearest_ok);
    EXPECT_TRUE(distance_ok) << "voxel " << v << ": got " << got << ", expected " << expected;
    EXPECT_TRUE(nearest_ok) << "voxel " << v << ": nearest " << nearest << " is not a nearest "
                            << "feature (expected squared distance " << expected << ")";
  }
}

struct Case {
  std::array<int, 3> dims;
  double density;
};

const Case kCases[] = {
    {{17, 13, 9}, 0.01},    {{17, 13, 9}, 0.1},    {{17, 13, 9}, 0.5},   {{17, 13, 9}, 0.97},
    {{1, 1, 1}, 1.0},       {{1, 20, 7}, 0.05},    {{23, 1, 5}, 0.05},   {{9, 11, 1}, 0.05},
    {{31, 1, 1}, 0.1},      {{1, 1, 25}, 0.1},     {{1, 1, 25}, 0.0},    {{6, 7, 8}, 0.3},
    {{70, 41, 19}, 0.0005}, {{37, 66, 33}, 0.001}, {{3, 35, 70}, 0.002},
};

const Vec3 kSpacings[] = {{1, 1, 1}, {0.617, 0.617, 1.333}, {2.5, 0.3, 1.1}};

TEST(DistanceTransform, MatchesBruteForce) {
  unsigned seed = 1;
  for (const Vec3& spacing : kSpacings)
    for (const Case& c : kCases) {
      SCOPED_TRACE(::testing::Message() << "dims " << c.dims[0] << "×" << c.dims[1] << "×"
                                        << c.dims[2] << ", density " << c.density << ", spacing "
                                        << spacing.x << "," << spacing.y << "," << spacing.z);
      expect_matches_brute_force(random_mask(c.dims, spacing, c.density, seed++));
    }
}

TEST(DistanceTransform, LargeShapeSampled) {
  // Features outside an off-centre ellipsoid, plus a few inside: long runs of features and long
  // feature-free segments in every direction, over several tiles of lines.
  Grid g;
  g.dims = {75, 53, 41};
  g.spacing = {0.617, 0.617, 1.333};
  Mask m(g);
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i) {
        const double x = (i - 40.0) / 33, y = (j - 25.0) / 24, z = (k - 19.0) / 18;
        m.at(i, j, k) = x * x + y * y + z * z > 1.0;
      }
  m.at(40, 25, 19) = m.at(30, 20, 10) = m.at(55, 30, 25) = 1;
  expect_matches_brute_force(m, 127);
}

TEST(DistanceTransform, PlaneOfFeaturesKeepsEveryParabola) {
  // Features fill the plane i = 0, so along j and k every sample away from it has the same
  // value: every parabola of such a line stays on its lower envelope, the deepest stack a line
  // of the longest axis can build.
  Grid g;
  g.dims = {7, 40, 23};
  g.spacing = {0.617, 0.617, 1.333};
  Mask m(g);
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j) m.at(0, j, k) = 1;
  expect_matches_brute_force(m);
}

TEST(DistanceTransform, EquidistantFeaturesBothValid) {
  // Two features symmetric about the middle plane: every voxel of that plane is a tie.
  Grid g;
  g.dims = {9, 5, 4};
  g.spacing = {0.617, 0.617, 1.333};
  Mask m(g);
  m.at(0, 2, 1) = 1;
  m.at(8, 2, 1) = 1;
  expect_matches_brute_force(m);
}

TEST(DistanceTransform, NoFeatures) {
  const Mask m = random_mask({12, 7, 5}, {0.617, 0.617, 1.333}, 0.0, 3);
  for (bool nearest : {true, false}) {
    const FeatureTransform ft = cvt::compute_feature_transform(m, nearest);
    for (float d : ft.squared_distance_mm2.data) ASSERT_TRUE(std::isinf(d) && d > 0);
    if (nearest)
      for (std::int32_t n : ft.nearest.data) ASSERT_EQ(n, -1);
  }
}

TEST(DistanceTransform, AllFeatures) {
  const Mask m = random_mask({40, 9, 6}, {0.617, 0.617, 1.333}, 1.0, 4);
  const FeatureTransform ft = cvt::compute_feature_transform(m);
  for (std::size_t v = 0; v < m.size(); ++v) {
    ASSERT_EQ(ft.squared_distance_mm2.data[v], 0.0f);
    ASSERT_EQ(ft.nearest.data[v], std::int32_t(v));
  }
}

TEST(DistanceTransform, SingleFeature) {
  Grid g;
  g.dims = {50, 40, 30};
  g.spacing = {0.617, 0.617, 1.333};
  Mask m(g);
  m.at(11, 27, 4) = 1;
  const FeatureTransform ft = cvt::compute_feature_transform(m);
  const std::int32_t feature = std::int32_t(g.linear(11, 27, 4));
  for (std::size_t v = 0; v < m.size(); ++v) {
    ASSERT_EQ(ft.nearest.data[v], feature);
    const double expected = squared_distance(g, v, feature);
    ASSERT_NEAR(ft.squared_distance_mm2.data[v], expected, tolerance(expected));
  }
}

TEST(DistanceTransform, EmptyGrid) {
  Grid g;
  g.dims = {0, 4, 4};
  const FeatureTransform ft = cvt::compute_feature_transform(Mask(g));
  EXPECT_EQ(ft.squared_distance_mm2.size(), 0u);
  EXPECT_EQ(ft.nearest.size(), 0u);
}

TEST(DistanceTransform, RejectsMaskNotMatchingGrid) {
  Mask m = random_mask({4, 4, 4}, {1, 1, 1}, 0.5, 5);
  m.data.pop_back();
  EXPECT_THROW(cvt::compute_feature_transform(m), cvt::InputError);
}

TEST(DistanceTransform, RejectsNonPositiveSpacing) {
  Mask m = random_mask({4, 4, 4}, {1, 0, 1}, 0.5, 7);
  EXPECT_THROW(cvt::compute_feature_transform(m), cvt::InputError);
}

TEST(DistanceTransform, ExtremeSpacingsGiveNoNaN) {
  // Squared spacings w beyond float's range (w·d² rounds to 0 for spacings near 1e-21 mm, to
  // +inf near 1e21 mm): distances then round to 0 or +inf, but stay ordered: features 0, nothing
  // negative or NaN.
  for (double tiny_or_huge : {1e-21, 1e21}) {
    SCOPED_TRACE(tiny_or_huge);
    Mask m = random_mask({20, 40, 40}, {1.0, tiny_or_huge, tiny_or_huge}, 0.01, 11);
    for (bool nearest : {true, false}) {
      const FeatureTransform ft = cvt::compute_feature_transform(m, nearest);
      for (std::size_t v = 0; v < m.size(); ++v) {
        const float d = ft.squared_distance_mm2.data[v];
        ASSERT_FALSE(std::isnan(d)) << "voxel " << v;
        ASSERT_GE(d, 0.0f) << "voxel " << v;
        if (m.data[v]) ASSERT_EQ(d, 0.0f) << "voxel " << v;
      }
    }
  }
}

TEST(DistanceTransform, ReusedOutputsMatchFreshOnes) {
  // One output reused across grids of other sizes and masks, with and without the feature
  // volume: stale values from an earlier mask must never leak into a later result.
  const Mask masks[] = {
      random_mask({31, 17, 11}, {0.617, 0.617, 1.333}, 0.02, 11),
      random_mask({31, 17, 11}, {0.617, 0.617, 1.333}, 0.3, 12),
      random_mask({9, 40, 6}, {2.5, 0.3, 1.1}, 0.01, 13),
      random_mask({31, 17, 11}, {1, 1, 1}, 0.0, 14),
      random_mask({50, 20, 30}, {0.617, 0.617, 1.333}, 0.001, 15),
  };
  FeatureTransform out;
  for (bool nearest : {true, false, true})
    for (const Mask& m : masks) {
      cvt::compute_feature_transform(m, out, nearest);
      const FeatureTransform fresh = cvt::compute_feature_transform(m, nearest);
      EXPECT_EQ(out.squared_distance_mm2.grid.dims, m.grid.dims);
      ASSERT_EQ(out.squared_distance_mm2.size(), m.size());
      EXPECT_EQ(std::memcmp(out.squared_distance_mm2.data.data(),
                            fresh.squared_distance_mm2.data.data(), m.size() * sizeof(float)),
                0);
      EXPECT_EQ(out.nearest.data, fresh.nearest.data);
      EXPECT_EQ(out.nearest.data.size(), nearest ? m.size() : 0u);
    }
}

TEST(DistanceTransform, LongLinesMatchBruteForce) {
  // Long lines, widths that are no multiple of the tile width, tiles mixing lines with and
  // without features, planes of features, sparse features (long-range ties) and strong
  // anisotropy. Every mask is checked against brute force on a sample of voxels (sized to keep
  // the O(N·F) check cheap), and the distance-only transform against the FT everywhere.
  std::vector<Mask> masks;
  const Vec3 spacings[] = {{0.617, 0.617, 1.333}, {2.5, 0.3, 1.1}, {1e-3, 7.0, 0.1}};
  unsigned seed = 100;
  for (const Vec3& spacing : spacings)
    for (double density : {0.0005, 0.01, 0.3, 0.9}) {
      masks.push_back(random_mask({29, 83, 61}, spacing, density, seed++));
      masks.push_back(random_mask({45, 17, 130}, spacing, density, seed++));
    }
  {  // an ellipsoid's complement, as in the benchmark, and a half-empty variant
    Grid g;
    g.dims = {45, 70, 38};
    g.spacing = {0.617, 0.617, 1.333};
    Mask m(g), half(g);
    for (int k = 0; k < g.dims[2]; ++k)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int i = 0; i < g.dims[0]; ++i) {
          const double x = (i - 22) / 20.0, y = (j - 35) / 31.0, z = (k - 19) / 17.0;
          m.at(i, j, k) = x * x + y * y + z * z > 1.0 ? 1 : 0;
          // features only on lines with i ≥ 13, and there only near one end of each line
          half.at(i, j, k) = i >= 13 && j + k < 6 ? 1 : 0;
        }
    masks.push_back(m);
    masks.push_back(half);
    Mask plane(g);  // one plane of features: every line's parabolas are all on the envelope
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i) plane.at(i, j, 0) = 1;
    masks.push_back(plane);
    Mask full(g);
    std::fill(full.data.begin(), full.data.end(), 1);
    masks.push_back(full);
    masks.push_back(Mask(g));  // no feature
  }
  for (std::size_t c = 0; c < masks.size(); ++c) {
    const Mask& m = masks[c];
    SCOPED_TRACE(::testing::Message() << "mask " << c);
    const auto features = std::size_t(std::count(m.data.begin(), m.data.end(), 1));
    // About 5·10⁷ voxel–feature pairs per mask; an odd stride, so samples move across lines.
    const std::size_t check_every = std::max<std::size_t>(7, m.size() * features / 50'000'000) | 1;
    expect_matches_brute_force(m, check_every);
  }
}

FeatureTransform run_with_threads(const Mask& m, int threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  return cvt::compute_feature_transform(m);
}

TEST(DistanceTransform, IdenticalForAnyThreadCount) {
  // Sparse features (many long-range ties) and a grid wider than one tile.
  const Mask m = random_mask({131, 97, 43}, {0.617, 0.617, 1.333}, 0.0003, 6);
  const FeatureTransform one = run_with_threads(m, 1);
  FeatureTransform one_distance_only;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one_distance_only = cvt::compute_feature_transform(m, false);
  }
  for (int threads : {2, 3}) {
    const FeatureTransform many = run_with_threads(m, threads);
    EXPECT_EQ(std::memcmp(one.squared_distance_mm2.data.data(),
                          many.squared_distance_mm2.data.data(), m.size() * sizeof(float)),
              0)
        << threads << " threads";
    EXPECT_EQ(one.nearest.data, many.nearest.data) << threads << " threads";
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const FeatureTransform distance_only = cvt::compute_feature_transform(m, false);
    EXPECT_EQ(std::memcmp(one_distance_only.squared_distance_mm2.data.data(),
                          distance_only.squared_distance_mm2.data.data(), m.size() * sizeof(float)),
              0)
        << threads << " threads, distance only";
  }
}

}  // namespace
