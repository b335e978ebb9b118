// Stage 1 on analytic phantoms: object selection, clean-up, medial axis and local feature size.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "preprocess/cleanup.h"
#include "base/errors.h"
#include "phantoms.h"
#include "preprocess/preprocess.h"
#include "fields/smoothing.h"

using namespace cvt;

namespace {

const double kPi = 3.14159265358979323846;

double max_spacing(const Grid& g) { return std::max({g.spacing.x, g.spacing.y, g.spacing.z}); }

struct LfsErrors {
  double max_abs = 0;
  double mean_abs = 0;
  std::size_t count = 0;
};

// Compares lfs at the boundary voxels accepted by `use` against `expected(world position)`.
template <class Expected, class Use>
LfsErrors lfs_errors(const PreprocessResult& r, Expected expected, Use use) {
  LfsErrors e;
  for (std::int32_t v : r.boundary) {
    const Vec3 w = r.object.grid.voxel_to_world(std::size_t(v));
    if (!use(w)) continue;
    const double err = std::abs(double(r.lfs_mm.data[v]) - expected(w));
    e.max_abs = std::max(e.max_abs, err);
    e.mean_abs += err;
    ++e.count;
  }
  if (e.count) e.mean_abs /= double(e.count);
  return e;
}

}  // namespace

TEST(LocalFeatureSize, SphereSurfaceIsRadiusWithinOneVoxel) {
  const double R = 12.0;
  const Phantom p = sphere_phantom({3, -4, 5}, R);
  const Grid g = grid_around(p, {0.8, 0.9, 1.2}, rotation_matrix({1, 2, 3}, 0.5));
  PreprocessOptions opt;
  opt.lfs.max_mm = 100;  // no upper clamp in the way
  const PreprocessResult r = preprocess(rasterize(p, g), opt);
  ASSERT_GT(r.boundary.size(), 1000u);
  const auto e = lfs_errors(r, [&](const Vec3&) { return R; }, [](const Vec3&) { return true; });
  EXPECT_LE(e.max_abs, max_spacing(g)) << "mean " << e.mean_abs;
  // The inner medial axis of a ball is its centre: a few voxels only, no spurious branches.
  const auto inner = std::count(r.medial_axis.data.begin(), r.medial_axis.data.end(), 1);
  const auto outer = std::count(r.medial_axis.data.begin(), r.medial_axis.data.end(), 2);
  EXPECT_GE(inner, 1);
  EXPECT_LE(inner, 27);
  EXPECT_EQ(outer, 0);
}

TEST(LocalFeatureSize, SlabFacesAreHalfThickness) {
  const double t = 6.0, half_width = 18.0;
  const Vec3 c{-7, 2, 40};
  const Phantom p = slab_phantom(c, t, half_width);
  const Grid g = grid_around(p, {0.7, 0.7, 0.5}, rotation_matrix({0, 0, 1}, 0.0));
  PreprocessOptions opt;
  const PreprocessResult r = preprocess(rasterize(p, g), opt);
  // Voxels on the two large faces, away from the edges (whose medial sheets are nearer).
  auto on_face = [&](const Vec3& w) {
    const Vec3 q = w - c;
    return std::abs(q.x) < half_width - t && std::abs(q.y) < half_width - t;
  };
  const auto e = lfs_errors(r, [&](const Vec3&) { return t / 2; }, on_face);
  ASSERT_GT(e.count, 500u);
  EXPECT_LE(e.max_abs, max_spacing(g)) << "mean " << e.mean_abs;
}

TEST(LocalFeatureSize, TorusIsMinOfMinorRadiusAndAxisDistance) {
  // The hole (radius 4 mm) is narrower than the tube (radius 6 mm), so near the inner equator
  // the outer medial axis (the z axis) is nearer than the tube's core circle.
  const double major = 10.0, minor = 6.0;
  const Vec3 c{20, 10, -15};
  const Phantom p = torus_phantom(c, major, minor);
  const Grid g = grid_around(p, {0.6, 0.75, 0.9}, rotation_matrix({1, -1, 2}, 0.7));
  PreprocessOptions opt;
  const PreprocessResult r = preprocess(rasterize(p, g), opt);
  auto expected = [&](const Vec3& w) {
    const Vec3 q = w - c;
    const double axis = std::hypot(q.x, q.y);
    const double core = std::hypot(axis - major, q.z);
    return std::min(core, axis);
  };
  const auto e = lfs_errors(r, expected, [](const Vec3&) { return true; });
  ASSERT_GT(e.count, 1000u);
  EXPECT_LE(e.max_abs, 1.5 * max_spacing(g)) << "mean " << e.mean_abs;
  EXPECT_LE(e.mean_abs, 0.5 * max_spacing(g));
  // Both medial axes exist: the core circle inside, the z axis outside.
  EXPECT_GT(std::count(r.medial_axis.data.begin(), r.medial_axis.data.end(), 1), 20);
  EXPECT_GT(std::count(r.medial_axis.data.begin(), r.medial_axis.data.end(), 2), 5);
}

TEST(LocalFeatureSize, ClampedToBounds) {
  const Phantom p = sphere_phantom({0, 0, 0}, 10.0);
  const Grid g = grid_around(p, {1, 1, 1}, rotation_matrix({0, 0, 1}, 0));
  PreprocessOptions opt;
  opt.lfs.min_mm = 2.5;
  opt.lfs.max_mm = 4.0;
  const PreprocessResult r = preprocess(rasterize(p, g), opt);
  const auto [lo, hi] = std::minmax_element(r.lfs_mm.data.begin(), r.lfs_mm.data.end());
  EXPECT_FLOAT_EQ(*lo, 2.5f);
  EXPECT_FLOAT_EQ(*hi, 4.0f);
}

// nearest_opposite(pre, v, d) against a brute-force search: a voxel of the other phase at the
// nearest distance when that is within d, else none. Isotropic, where the kept offsets reach
// every answer, and 6:1 anisotropic, where the nearest voxel within 5 coarse spacings can lie
// beyond the offsets' 15 fine voxels and is searched for.
TEST(Preprocess, NearestOppositeIsANearestVoxelOfTheOtherPhaseWithinTheDistance) {
  const std::pair<Phantom, Vec3> cases[] = {{sphere_phantom({1, -2, 3}, 30.0), {0.95, 1.0, 1.05}},
                                            {sphere_phantom({1, -2, 3}, 7.0), {0.2, 0.2, 1.2}}};
  for (const auto& [p, spacing] : cases) {
    const PreprocessResult r =
        preprocess(rasterize(p, grid_around(p, spacing, rotation_matrix({1, 2, 3}, 0.5))), {});
    const Mask& m = r.object;
    const Grid& c = m.grid;
    auto dist2 = [&](std::size_t a, std::size_t b) {
      const auto x = c.ijk(a), y = c.ijk(b);
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += std::pow((x[k] - y[k]) * c.spacing[k], 2);
      return d2;
    };
    // A nearest voxel of the other phase has a 6-neighbour of v's phase: search only those.
    std::vector<std::size_t> rim[2];
    for (std::size_t u = 0; u < m.size(); ++u) {
      const auto q = c.ijk(u);
      bool edge = false;
      for (int a = 0; a < 3; ++a)
        for (int step : {-1, 1}) {
          auto n = q;
          n[a] += step;
          edge |= c.contains(n[0], n[1], n[2]) && m.at(n[0], n[1], n[2]) != m.data[u];
        }
      if (edge) rim[m.data[u]].push_back(u);
    }
    const double coarse = max_spacing(c);
    std::size_t found = 0, beyond_offsets = 0, none = 0;
    for (std::size_t v = 0; v < m.size(); v += 97) {
      double best = INFINITY;
      for (std::size_t u : rim[1 - m.data[v]]) best = std::min(best, dist2(v, u));
      for (const double within : {1.5 * coarse, 5.0 * coarse}) {
        const std::int64_t u = nearest_opposite(r, v, within);
        if (best > within * within) {
          EXPECT_EQ(u, -1) << v;
          none += u == -1;
          continue;
        }
        ASSERT_GE(u, 0) << v;
        ASSERT_LT(std::size_t(u), m.size());
        EXPECT_NE(m.data[std::size_t(u)], m.data[v]) << v;
        EXPECT_NEAR(dist2(v, std::size_t(u)), best, 1e-9) << v;
        ++found;
        const auto a = c.ijk(v), b = c.ijk(std::size_t(u));
        for (int k = 0; k < 3; ++k) beyond_offsets += std::abs(a[k] - b[k]) > kNearestOppositeReach;
      }
    }
    EXPECT_GT(found, 300u) << p.name;
    EXPECT_GT(none, 30u) << p.name;
    if (spacing.z / spacing.x > 3) EXPECT_GT(beyond_offsets, 0u) << "the search is exercised";
  }
}

TEST(ObjectSelection, CropKeepsWorldPositionsAndPadsBorderObjects) {
  // A sphere that pokes out of the image on one side must come back closed.
  const Phantom p = sphere_phantom({0, 0, 0}, 8.0);
  Grid g = grid_around(p, {1, 1.25, 1.5}, rotation_matrix({0, 1, 0}, 0.3));
  g.dims[0] -= 5;  // cut the image so the object touches its border
  Image img = rasterize(p, g);
  ObjectSelection sel;
  sel.margin_voxels = 2;
  const Mask m = select_object(img, sel);
  const Grid& mg = m.grid;
  std::size_t inside = 0;
  for (int k = 0; k < mg.dims[2]; ++k)
    for (int j = 0; j < mg.dims[1]; ++j)
      for (int i = 0; i < mg.dims[0]; ++i) {
        const bool border = i == 0 || j == 0 || k == 0 || i == mg.dims[0] - 1 ||
                            j == mg.dims[1] - 1 || k == mg.dims[2] - 1;
        if (border) EXPECT_EQ(m.at(i, j, k), 0);
        if (!m.at(i, j, k)) continue;
        ++inside;
        // The same world point is inside in the original image.
        const Vec3 idx = g.world_to_index(mg.index_to_world({double(i), double(j), double(k)}));
        const int si = int(std::lround(idx.x)), sj = int(std::lround(idx.y)), sk = int(std::lround(idx.z));
        ASSERT_TRUE(g.contains(si, sj, sk));
        EXPECT_NEAR(idx.x, si, 1e-6);
        EXPECT_EQ(img.voxels.at(si, sj, sk), 1.0f);
      }
  const auto total = std::count(img.voxels.data.begin(), img.voxels.data.end(), 1.0f);
  EXPECT_EQ(inside, std::size_t(total));
}

TEST(ObjectSelection, LabelsIsoAndErrors) {
  Grid g;
  g.dims = {6, 6, 6};
  Image img;
  img.voxels = Volume<float>(g, 0.0f);
  img.source = "labels.nii";
  img.voxels.at(1, 1, 1) = 3;
  img.voxels.at(4, 4, 4) = 7;
  ObjectSelection sel;
  sel.labels = {7};
  Mask m = select_object(img, sel);
  EXPECT_EQ(std::count(m.data.begin(), m.data.end(), 1), 1);
  sel.labels = {3, 7};
  m = select_object(img, sel);
  EXPECT_EQ(std::count(m.data.begin(), m.data.end(), 1), 2);
  sel.labels = {5};
  try {
    select_object(img, sel);
    FAIL() << "empty selection accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("labels.nii"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("label 5"), std::string::npos) << e.what();
  }
  // Grey images need an iso value; below/above select complementary sets.
  img.integer_valued = false;
  img.pixel_type = "float32";
  sel = {};
  EXPECT_THROW(select_object(img, sel), InputError);
  sel.iso = 5.0;
  m = select_object(img, sel);
  EXPECT_EQ(std::count(m.data.begin(), m.data.end(), 1), 1);
  img.voxels.at(2, 2, 2) = std::nanf("");
  EXPECT_THROW(select_object(img, sel), InputError);
  EXPECT_EQ(parse_label_list("all").size(), 0u);
  EXPECT_EQ(parse_label_list("1,20,255"), (std::vector<std::int64_t>{1, 20, 255}));
  EXPECT_THROW(parse_label_list("1,x"), InputError);
}

// A shell's cavity is an eighth of the ball (a seventh of the shell): too large to fill by
// default, so the shell keeps both boundaries; filled only when the user allows cavities that
// large.
TEST(Cleanup, KeepsALargeCavityAndDropsSpecks) {
  const Phantom p = hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0);
  const Grid g = grid_around(p, {1, 1, 1}, rotation_matrix({0, 0, 1}, 0));
  Image img = rasterize(p, g);
  img.voxels.at(1 + 2, 2, 2) = 1;  // a speck far from the shell, inside the margin
  ObjectSelection sel;
  Mask keep = select_object(img, sel);
  Mask shell = keep, cleaned = keep;
  CleanupOptions off;
  off.remove_small_components = false;
  off.fill_cavities = false;
  const CleanupReport none = clean_object(keep, off);
  EXPECT_EQ(none.components, 2);
  EXPECT_EQ(none.cavities_filled + none.cavities_kept, 0);
  const CleanupReport by_default = clean_object(shell, CleanupOptions{});
  EXPECT_EQ(by_default.components_removed, 1);
  EXPECT_EQ(by_default.cavities_filled, 0);
  EXPECT_EQ(by_default.cavities_kept, 1);
  std::vector<int> labels;
  EXPECT_EQ(label_components(shell, 0, labels).size(), 2u);  // outside and the cavity
  CleanupOptions fill_all;
  fill_all.max_cavity_fraction = 1;
  const CleanupReport rep = clean_object(cleaned, fill_all);
  EXPECT_EQ(rep.components, 2);
  EXPECT_EQ(rep.components_removed, 1);
  EXPECT_EQ(rep.voxels_removed, 1u);
  EXPECT_EQ(rep.cavities_filled, 1);
  EXPECT_EQ(rep.cavities_kept, 0);
  EXPECT_EQ(rep.voxels_filled, by_default.voxels_kept);
  EXPECT_EQ(label_components(cleaned, 1, labels).size(), 1u);
  EXPECT_EQ(label_components(cleaned, 0, labels).size(), 1u);  // no cavity left
  // The filled voxels are exactly those within the inner radius.
  const std::size_t before = std::count(keep.data.begin(), keep.data.end(), 1);
  const std::size_t after = std::count(cleaned.data.begin(), cleaned.data.end(), 1);
  EXPECT_EQ(after, before - 1 + rep.voxels_filled);
  EXPECT_NEAR(double(rep.voxels_filled), 4.0 / 3.0 * kPi * 64.0, 0.15 * 4.0 / 3.0 * kPi * 64.0);
}

// A cavity is filled when it holds at most max_cavity_fraction of the object's voxels (the
// specks already dropped), and kept when it holds one voxel more than that.
TEST(Cleanup, FillsACavityUpToTheFractionOfTheObject) {
  const Phantom p = hollow_sphere_phantom({0, 0, 0}, 1.6, 8.0);
  const Grid g = grid_around(p, {1, 1, 1}, rotation_matrix({0, 0, 1}, 0));
  const Mask object = select_object(rasterize(p, g), ObjectSelection{});
  CleanupOptions off;
  off.fill_cavities = false;
  Mask probe = object;
  clean_object(probe, off);
  std::vector<int> labels;
  const std::vector<std::size_t> background = label_components(probe, 0, labels);
  ASSERT_EQ(background.size(), 2u);
  const double cavity = double(std::min(background[0], background[1]));
  const double voxels = double(std::count(probe.data.begin(), probe.data.end(), 1));
  EXPECT_LT(cavity / voxels, 0.01);  // small: the default fills it
  Mask by_default = object;
  EXPECT_EQ(clean_object(by_default, CleanupOptions{}).cavities_filled, 1);
  for (const double extra : {0.0, -1.0}) {
    Mask m = object;
    CleanupOptions o;
    o.max_cavity_fraction = (cavity + extra) / voxels;
    const CleanupReport r = clean_object(m, o);
    EXPECT_EQ(r.cavities_filled, extra == 0 ? 1 : 0) << extra;
    EXPECT_EQ(r.cavities_kept, extra == 0 ? 0 : 1) << extra;
  }
}

TEST(Preprocess, BoundaryVoxelsTouchBackground) {
  const Phantom p = torus_phantom({0, 0, 0}, 8.0, 3.0);
  const Grid g = grid_around(p, {0.8, 0.8, 1.0}, rotation_matrix({1, 0, 0}, 0.4));
  const PreprocessResult r = preprocess(rasterize(p, g), PreprocessOptions{});
  const Grid& mg = r.object.grid;
  std::size_t expected = 0;
  for (int k = 1; k + 1 < mg.dims[2]; ++k)
    for (int j = 1; j + 1 < mg.dims[1]; ++j)
      for (int i = 1; i + 1 < mg.dims[0]; ++i)
        if (r.object.at(i, j, k) &&
            (!r.object.at(i - 1, j, k) || !r.object.at(i + 1, j, k) || !r.object.at(i, j - 1, k) ||
             !r.object.at(i, j + 1, k) || !r.object.at(i, j, k - 1) || !r.object.at(i, j, k + 1)))
          ++expected;
  EXPECT_EQ(r.boundary.size(), expected);
  // The smoothed indicator crosses 0.5 between inside and outside.
  for (std::int32_t v : r.boundary) EXPECT_GT(r.indicator.data[v], 0.2f);
}

// The smoothed indicator is a separable Gaussian (truncated at 3σ, borders clamped, lines that
// are constant left alone): computed here one line at a time, the plain way, it is bitwise the
// same on an anisotropic, rotated torus.
TEST(SmoothedIndicator, BitwiseTheSeparableGaussianLineByLine) {
  const Phantom p = torus_phantom({1, -2, 3}, 8.0, 3.0);
  const Image image = rasterize(p, grid_around(p, {0.6, 0.7, 1.3}, rotation_matrix({1, 1, 0}, 0.4)));
  Mask mask(image.grid(), 0);
  for (std::size_t v = 0; v < mask.size(); ++v) mask.data[v] = image.voxels.data[v] != 0;
  const double sigma = 0.65;
  const Volume<float> got = smooth_indicator(mask, sigma);

  Volume<float> f(mask.grid, 0.0f);
  for (std::size_t v = 0; v < mask.size(); ++v) f.data[v] = mask.data[v] ? 1.0f : 0.0f;
  const Grid& g = mask.grid;
  for (int axis = 0; axis < 3; ++axis) {
    const double sv = sigma / g.spacing[axis];
    if (sv < 0.2) continue;
    const int radius = std::max(1, int(std::ceil(3.0 * sv)));
    std::vector<float> k(2 * radius + 1);
    double sum = 0;
    for (int t = -radius; t <= radius; ++t) sum += k[t + radius] = float(std::exp(-0.5 * t * t / (sv * sv)));
    for (float& w : k) w = float(w / sum);
    const int n = g.dims[axis];
    std::array<int, 3> c{};
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (c[a2] = 0; c[a2] < g.dims[a2]; ++c[a2])
      for (c[a1] = 0; c[a1] < g.dims[a1]; ++c[a1]) {
        std::vector<float> line(n);
        for (int t = 0; t < n; ++t) {
          std::array<int, 3> q = c;
          q[axis] = t;
          line[t] = f.at(q[0], q[1], q[2]);
        }
        if (std::all_of(line.begin(), line.end(), [&](float x) { return x == line[0]; })) continue;
        for (int t = 0; t < n; ++t) {
          float acc = 0;
          for (int s = -radius; s <= radius; ++s) acc += k[s + radius] * line[std::clamp(t + s, 0, n - 1)];
          std::array<int, 3> q = c;
          q[axis] = t;
          f.at(q[0], q[1], q[2]) = acc;
        }
      }
  }
  ASSERT_EQ(got.data.size(), f.data.size());
  std::size_t differ = 0, between = 0;
  for (std::size_t v = 0; v < f.size(); ++v) {
    differ += got.data[v] != f.data[v];
    between += f.data[v] > 0.01f && f.data[v] < 0.99f;
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(between, 1000u);  // the smoothing did smooth
}
