// Stage 7: Table I measures, dihedral angles, radius–edge ratio and mesh validity.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numeric>
#include <random>

#include "base/errors.h"
#include "fields/marching_cubes.h"
#include "phantoms.h"
#include "evaluate/quality.h"

using namespace cvt;

namespace {

// Edge 2√2, centred at the origin, positively oriented.
const Vec3 kRegular[4] = {{1, 1, 1}, {-1, 1, -1}, {1, -1, -1}, {-1, -1, 1}};

TetMesh single_tet(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  TetMesh m;
  m.vertices = {a, b, c, d};
  m.tets = {{0, 1, 2, 3}};
  return m;
}

Mask to_mask(const Image& image) {
  Mask mask(image.grid());
  for (std::size_t i = 0; i < mask.size(); ++i) mask.data[i] = image.voxels.data[i] > 0.5f;
  return mask;
}

Mask phantom_mask(const Phantom& p) {
  return to_mask(rasterize(p, grid_around(p, {0.7, 0.8, 1.1}, rotation_matrix({1, 2, 0.5}, 0.6))));
}

Mask box_mask(int n) {
  Grid g;
  g.dims = {n, n, n};
  g.spacing = {1.0, 1.5, 0.5};
  return Mask(g, 0);
}

double measure(const Vec3* p, Measure m) {
  return tet_measure(p[0], p[1], p[2], p[3], m);
}

}  // namespace

TEST(Quality, RegularTetScoresTheTableValues) {
  ASSERT_GT(
      dot(kRegular[1] - kRegular[0], cross(kRegular[2] - kRegular[0], kRegular[3] - kRegular[0])),
      0);
  const double q1 = measure(kRegular, Measure::VOverRmc3);
  const double q2 = measure(kRegular, Measure::GradientError);
  const double q3 = measure(kRegular, Measure::ConditionNumber);
  EXPECT_NEAR(q1, 0.5132, 5e-5);
  EXPECT_NEAR(q2, 0.1629, 5e-5);
  EXPECT_NEAR(q3, 0.4136, 5e-5);
  // DESIGN's normalisers map the regular tet to 1.
  EXPECT_NEAR(q1 * 9 * std::sqrt(3.0) / 8, 1.0, 1e-12);
  EXPECT_NEAR(q2 * std::pow(3.0, 17.0 / 8) / std::pow(2.0, 0.75), 1.0, 1e-12);
  EXPECT_NEAR(q3 * std::pow(3.0, 7.0 / 4) / std::pow(2.0, 1.5), 1.0, 1e-12);
  for (Measure m : kShewchukMeasures)
    EXPECT_NEAR(measure(kRegular, m), regular_tet_value(m), 1e-12);
  for (double angle : dihedral_angles_deg(kRegular[0], kRegular[1], kRegular[2], kRegular[3]))
    EXPECT_NEAR(angle, 70.5288, 5e-5);
  EXPECT_NEAR(measure(kRegular, Measure::RadiusEdge), std::sqrt(6.0) / 4, 1e-12);
  EXPECT_NEAR(min_containing_ball_radius(kRegular[0], kRegular[1], kRegular[2], kRegular[3]),
              std::sqrt(3.0), 1e-12);
}

TEST(Quality, SliversAndFlatTetsScoreZero) {
  for (double eps : {1e-5, 0.0}) {
    const Vec3 sliver[4] = {{0, 0, 0}, {1, 1, 0}, {1, 0, eps}, {0, 1, eps}};
    for (Measure m : kShewchukMeasures) EXPECT_NEAR(measure(sliver, m), 0, 1e-4) << eps;
    EXPECT_LT(measure(sliver, Measure::MinDihedralDeg), 0.01);
    EXPECT_GT(measure(sliver, Measure::MaxDihedralDeg), 179.99);
  }
  // A sliver has a good radius–edge ratio (why it is not enough); a flat one an infinite one.
  const Vec3 sliver[4] = {{0, 0, 0}, {1, 1, 0}, {1, 0, 1e-5}, {0, 1, 1e-5}};
  EXPECT_NEAR(measure(sliver, Measure::RadiusEdge), std::sqrt(2.0) / 2, 1e-4);
  const Vec3 flat[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 0}};
  EXPECT_TRUE(std::isinf(measure(flat, Measure::RadiusEdge)));
  // Inverted: negative.
  const Vec3 inverted[4] = {kRegular[0], kRegular[2], kRegular[1], kRegular[3]};
  for (Measure m : kShewchukMeasures)
    EXPECT_NEAR(measure(inverted, m), -regular_tet_value(m), 1e-12);
}

TEST(Quality, MinContainingBallOfFacesAndEdges) {
  // Circumcentre outside: the ball of the long edge.
  EXPECT_NEAR(min_containing_ball_radius({-1, 0, 0}, {1, 0, 0}, {0, 0.1, 0}, {0, 0, 0.1}), 1.0,
              1e-12);
  // Low apex over an equilateral triangle: the triangle's circumcircle.
  const double s = std::sqrt(3.0) / 2;
  EXPECT_NEAR(min_containing_ball_radius({1, 0, 0}, {-0.5, s, 0}, {-0.5, -s, 0}, {0, 0, 0.1}), 1.0,
              1e-12);
  // Random tets: never above the circumradius, never below half the longest edge, and the
  // circumradius when its centre is inside.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int n = 0; n < 2000; ++n) {
    Vec3 p[4];
    for (auto& v : p) v = {u(rng), u(rng), u(rng)};
    const double r = min_containing_ball_radius(p[0], p[1], p[2], p[3]);
    double longest = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) longest = std::max(longest, distance(p[i], p[j]));
    EXPECT_LE(r, circumradius(p[0], p[1], p[2], p[3]) * (1 + 1e-9));
    EXPECT_GE(r, longest / 2 * (1 - 1e-9));
  }
}

TEST(Quality, MeasuresAreScaleAndRigidMotionInvariant) {
  const Vec3 p[4] = {{0.1, 0.2, 0.3}, {1.3, 0.1, 0.2}, {0.4, 1.1, -0.2}, {0.5, 0.4, 0.9}};
  const auto rot = rotation_matrix({1, -2, 0.7}, 1.1);
  Vec3 q[4];
  for (int i = 0; i < 4; ++i) {
    const Vec3 v = p[i] * 37.5;
    q[i] =
        Vec3{rot[0] * v.x + rot[1] * v.y + rot[2] * v.z, rot[3] * v.x + rot[4] * v.y + rot[5] * v.z,
             rot[6] * v.x + rot[7] * v.y + rot[8] * v.z} +
        Vec3{100, -20, 3};
  }
  for (Measure m : {Measure::VOverRmc3, Measure::GradientError, Measure::ConditionNumber,
                    Measure::MinDihedralDeg, Measure::MaxDihedralDeg, Measure::RadiusEdge})
    EXPECT_NEAR(measure(q, m), measure(p, m), 1e-9 * std::abs(measure(p, m))) << measure_key(m);
}

namespace {

// A ball's voxels as tets, every vertex moved by up to `jitter` along each axis: tets of
// all shapes, in every bin.
TetMesh jittered_ball_mesh(double radius, unsigned seed, double jitter) {
  TetMesh mesh = voxel_tet_mesh(phantom_mask(sphere_phantom({3, -2, 5}, radius)));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> move(-jitter, jitter);
  for (Vec3& v : mesh.vertices) v += Vec3{move(rng), move(rng), move(rng)};
  return mesh;
}

}  // namespace

TEST(Quality, TableBinsAddUpAndMatchPerTetValues) {
  const TetMesh mesh = jittered_ball_mesh(6.0, 3, 0.15);
  const QualityReport rep = compute_quality(mesh);
  EXPECT_EQ(rep.tets, mesh.tets.size());
  for (int i = 0; i < 3; ++i) {
    const MeasureStats& s = rep.shewchuk[i];
    EXPECT_NEAR(s.bins_percent[0] + s.bins_percent[1] + s.bins_percent[2], 100.0, 1e-9);
    EXPECT_EQ(std::accumulate(s.histogram.begin(), s.histogram.end(), std::size_t(0)), rep.tets);
    const std::vector<double> values = tet_measures(mesh)[std::size_t(kShewchukMeasures[i])];
    const auto edges = table1_bin_edges(kShewchukMeasures[i]);
    const auto low =
        std::count_if(values.begin(), values.end(), [&](double v) { return v < edges[0]; });
    EXPECT_NEAR(s.bins_percent[0], 100.0 * double(low) / double(values.size()), 1e-9);
    EXPECT_NEAR(s.min, *std::min_element(values.begin(), values.end()), 1e-15);
    EXPECT_LE(s.max, regular_tet_value(kShewchukMeasures[i]) + 1e-12);
  }
  const std::vector<double> min_dih = tet_measures(mesh)[std::size_t(Measure::MinDihedralDeg)];
  EXPECT_EQ(rep.dihedral.below_20, std::size_t(std::count_if(min_dih.begin(), min_dih.end(),
                                                             [](double a) { return a < 20; })));
  EXPECT_EQ(
      std::accumulate(rep.dihedral.histogram.begin(), rep.dihedral.histogram.end(), std::size_t(0)),
      6 * rep.tets);
  EXPECT_NEAR(rep.dihedral.min_deg, *std::min_element(min_dih.begin(), min_dih.end()), 1e-12);
  EXPECT_TRUE(rep.validity.valid);

  const nlohmann::json j = to_json(rep);
  EXPECT_EQ(j["tets"], rep.tets);
  EXPECT_EQ(j["measures"]["v_over_rmc3"]["bins_percent"].size(), 3u);
  EXPECT_EQ(j["measures"]["gradient_error"]["histogram"].size(), 20u);
  EXPECT_TRUE(j["dihedral_deg"].contains("below_10"));
  EXPECT_TRUE(j["radius_edge"].contains("mean"));
  EXPECT_EQ(j["validity"]["valid"], true);
  EXPECT_EQ(j["validity"]["euler_characteristic"], 2);
}

TEST(Quality, EveryMeasureAtOnceEqualsEachOnItsOwn) {
  const TetMesh mesh = jittered_ball_mesh(4.0, 5, 0.2);
  const auto all = tet_measures(mesh);
  for (int k = 0; k < kMeasureCount; ++k) {
    ASSERT_EQ(all[std::size_t(k)].size(), mesh.tets.size());
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
      const Tet& tet = mesh.tets[t];
      ASSERT_EQ(all[std::size_t(k)][t],
                tet_measure(mesh.vertices[tet[0]], mesh.vertices[tet[1]], mesh.vertices[tet[2]],
                            mesh.vertices[tet[3]], Measure(k)))
          << measure_key(Measure(k)) << " tet " << t;
    }
  }
}

// The extremes alone (two angles, found by a pseudo-angle) equal the extremes of all six angles
// (to 1e-9°: near-equal angles at 0° or 180° may swap) on random tets from regular to slivers,
// caps, needles and flat ones.
TEST(Quality, DihedralExtremesAloneEqualThoseOfAllSix) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> kind(0, 4);
  for (int n = 0; n < 20000; ++n) {
    Vec3 p[4];
    for (Vec3& q : p) q = {u(rng), u(rng), u(rng)};
    const int k = kind(rng);
    if (k == 1) p[3] = (p[0] + p[1] + p[2]) * (1.0 / 3) + Vec3{0, 0, 1e-4 * u(rng)};  // sliver/cap
    if (k == 2) p[3] = p[2] + (p[1] - p[2]) * 1e-5;                                   // needle
    if (k == 3) p[3] = p[0] + (p[1] - p[0]) * 0.3 + (p[2] - p[0]) * 0.4;              // flat
    if (k == 4) p[3] = p[2];                                                          // a face gone
    const TetFigures all = tet_figures(p[0], p[1], p[2], p[3], true);
    const TetFigures two = tet_figures(p[0], p[1], p[2], p[3], false);
    ASSERT_NEAR(two.min_dihedral, all.min_dihedral, 1e-9) << n << " kind " << k;
    ASSERT_NEAR(two.max_dihedral, all.max_dihedral, 1e-9) << n << " kind " << k;
    for (int m = 0; m < 3; ++m) ASSERT_EQ(two.shewchuk[m], all.shewchuk[m]);
  }
}

TEST(Validity, PhantomMeshesHaveTheRightTopology) {
  struct Case {
    Phantom phantom;
    long long euler;
    std::size_t components;
  };
  const Case cases[] = {{sphere_phantom({3, -2, 5}, 6.0), 2, 1},
                        {torus_phantom({1, 2, 3}, 8.0, 3.0), 0, 1},
                        {hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0), 4, 2}};
  for (const Case& c : cases) {
    const TetMesh mesh = voxel_tet_mesh(phantom_mask(c.phantom));
    const Validity v = check_validity(mesh);
    EXPECT_TRUE(v.valid) << c.phantom.name;
    EXPECT_TRUE(v.boundary.closed_manifold) << c.phantom.name;
    EXPECT_EQ(v.boundary.euler_characteristic, c.euler) << c.phantom.name;
    EXPECT_EQ(v.boundary.components, c.components) << c.phantom.name;
    EXPECT_EQ(v.inverted + v.zero_volume + v.unreferenced_vertices, 0u);
  }
  const Validity one =
      check_validity(single_tet(kRegular[0], kRegular[1], kRegular[2], kRegular[3]));
  EXPECT_TRUE(one.valid);
  EXPECT_EQ(one.boundary.euler_characteristic, 2);
  EXPECT_EQ(one.boundary.triangles, 4u);
}

TEST(Validity, BoundaryFacesAgreeWithBoundaryTriangles) {
  Mask mask = phantom_mask(torus_phantom({1, 2, 3}, 8.0, 3.0));
  TetMesh mesh = voxel_tet_mesh(mask);
  mesh.tets.push_back(mesh.tets[100]);  // a doubled tet: its faces are not boundary faces
  const FaceUse use = classify_faces(mesh);
  EXPECT_EQ(use.boundary, boundary_triangles(mesh));
  EXPECT_GE(use.overlapping + use.shared_by_more_than_two, 4u);
}

// Exact face counts on a fan of tets around one triangle (0, 1, 2): apexes above and below.
TEST(Validity, FaceUseCountsEachSharedTriangleOnce) {
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, 1}, {0.2, 0.2, -1}, {0.3, 0.3, 2}};
  const Tet above{0, 1, 2, 3}, below{0, 2, 1, 4}, above_again{0, 1, 2, 5};
  m.tets = {above, below};
  FaceUse use = classify_faces(m);  // a valid pair: the triangle is inside
  EXPECT_EQ(use.shared_by_more_than_two, 0u);
  EXPECT_EQ(use.overlapping, 0u);
  EXPECT_EQ(use.boundary.size(), 6u);
  m.tets = {above, above_again};  // both on the same side
  use = classify_faces(m);
  EXPECT_EQ(use.shared_by_more_than_two, 0u);
  EXPECT_EQ(use.overlapping, 1u);
  EXPECT_EQ(use.boundary.size(), 6u);
  m.tets = {above, below, above_again};  // three tets on one triangle
  use = classify_faces(m);
  EXPECT_EQ(use.shared_by_more_than_two, 1u);
  EXPECT_EQ(use.overlapping, 0u);
  EXPECT_EQ(use.boundary.size(), 9u);
  m.tets = {above, below, above_again, below};  // four, and the last two also share (0, 2, 4)…
  use = classify_faces(m);
  EXPECT_EQ(use.shared_by_more_than_two, 1u);
  EXPECT_EQ(use.overlapping, 3u);  // … and (1, 2, 4), (0, 1, 4), each twice on one side
  EXPECT_EQ(use.boundary.size(), 6u);
}

TEST(Validity, BrokenMeshesAreCaught) {
  Mask mask = box_mask(4);
  mask.at(1, 1, 1) = mask.at(2, 1, 1) = mask.at(1, 2, 1) = 1;
  const TetMesh good = voxel_tet_mesh(mask);
  ASSERT_TRUE(check_validity(good).valid);

  TetMesh inverted = good;
  std::swap(inverted.tets[5][0], inverted.tets[5][1]);
  Validity v = check_validity(inverted);
  EXPECT_EQ(v.inverted, 1u);
  EXPECT_FALSE(v.valid);

  TetMesh flat = good;
  flat.vertices[flat.tets[0][0]] = flat.vertices[flat.tets[0][1]];
  EXPECT_GE(check_validity(flat).zero_volume, 1u);

  TetMesh duplicated = good;
  duplicated.tets.push_back(duplicated.tets[7]);
  v = check_validity(duplicated);
  EXPECT_GE(v.faces_shared_by_more_than_two + v.overlapping_faces, 1u);
  EXPECT_FALSE(v.valid);

  TetMesh third = good;  // a face (the first tet's inner one) shared by three tets
  const Tet& t0 = good.tets[0];
  third.vertices.push_back({-5, -5, -5});
  third.tets.push_back({t0[1], t0[2], t0[3], std::int32_t(third.vertices.size() - 1)});
  EXPECT_GE(check_validity(third).faces_shared_by_more_than_two, 1u);

  TetMesh unreferenced = good;
  unreferenced.vertices.push_back({0, 0, 0});
  v = check_validity(unreferenced);
  EXPECT_EQ(v.unreferenced_vertices, 1u);
  EXPECT_TRUE(v.boundary.closed_manifold);
  EXPECT_FALSE(v.valid);

  // Two tets sharing only a vertex: a non-manifold vertex, one component, χ = 7 − 12 + 8.
  TetMesh touching = single_tet(kRegular[0], kRegular[1], kRegular[2], kRegular[3]);
  const Vec3 o = kRegular[0];
  for (int i = 1; i < 4; ++i) touching.vertices.push_back(o + (o - kRegular[i]));
  touching.tets.push_back({0, 4, 5, 6});
  if (signed_volume(touching, touching.tets[1]) < 0)
    std::swap(touching.tets[1][1], touching.tets[1][2]);
  v = check_validity(touching);
  EXPECT_EQ(v.boundary.non_manifold_vertices, 1u);
  EXPECT_EQ(v.boundary.non_manifold_edges, 0u);
  EXPECT_FALSE(v.boundary.closed_manifold);
  EXPECT_EQ(v.boundary.components, 1u);
  EXPECT_EQ(v.boundary.euler_characteristic, 3);
  EXPECT_FALSE(v.valid);

  // Two voxels sharing only an edge: four boundary triangles at each of its segments.
  Mask diagonal = box_mask(4);
  diagonal.at(1, 1, 1) = diagonal.at(2, 2, 1) = 1;
  v = check_validity(voxel_tet_mesh(diagonal));
  EXPECT_GE(v.boundary.non_manifold_edges, 1u);
  EXPECT_FALSE(v.valid);

  TetMesh bad_index = good;
  bad_index.tets[0][2] = 100000;
  EXPECT_THROW(check_validity(bad_index), InputError);
  EXPECT_THROW(compute_quality(bad_index), InputError);
}

TEST(Quality, EmptyMeshIsReportedNotValid) {
  const QualityReport rep = compute_quality(TetMesh{});
  EXPECT_EQ(rep.tets, 0u);
  EXPECT_FALSE(rep.validity.valid);
  EXPECT_EQ(rep.shewchuk[0].bins_percent[1], 0);
  EXPECT_NO_THROW(to_json(rep).dump());
}

TEST(Quality, AMillionTetsAreCheckedWhole) {
  Grid g;
  g.dims = {72, 72, 72};
  g.spacing = {0.6, 0.6, 1.3};
  Mask mask(g, 0);
  for (int k = 0; k < 72; ++k)
    for (int j = 0; j < 72; ++j)
      for (int i = 0; i < 72; ++i)
        mask.at(i, j, k) =
            (i - 35.5) * (i - 35.5) + (j - 35.5) * (j - 35.5) + (k - 35.5) * (k - 35.5) < 35 * 35;
  TetMesh mesh = voxel_tet_mesh(mask);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.1, 0.1);
  for (Vec3& v : mesh.vertices) v += Vec3{jitter(rng), jitter(rng), jitter(rng)};
  ASSERT_GT(mesh.tets.size(), 1000000u);
  const auto t0 = std::chrono::steady_clock::now();
  const QualityReport rep = compute_quality(mesh);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("compute_quality: %zu tets, %zu vertices in %.3f s\n", rep.tets, rep.vertices,
              seconds);
  EXPECT_TRUE(rep.validity.valid);
  EXPECT_EQ(rep.validity.boundary.euler_characteristic, 2);
  // Its speed is measured in bench/ (bench_kernels), not asserted here.
}
