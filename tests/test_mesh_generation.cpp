// Stage 5 on phantoms through the whole pipeline: a valid tet mesh whose boundary has the
// object's topology, close to the analytic volume, and the same mesh every time.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "io/image_io.h"
#include "meshing/mesh_generation.h"

#include "phantoms.h"
#include "pipeline/pipeline.h"
#include "evaluate/quality.h"

using namespace cvt;

namespace {

const double kPi = 3.14159265358979323846;

struct PhantomMesh {
  QualityReport quality;
  TetMesh mesh;
};

PhantomMesh mesh_phantom(const Phantom& p, Parameters params = {}) {
  Pipeline pipe;
  pipe.set_image(std::make_shared<Image>(
      rasterize(p, grid_around(p, {0.6, 0.7, 0.8}, rotation_matrix({1, 2, 2}, 0.5)))));
  pipe.set_parameters(params);
  pipe.run_through(Stage::optimize);
  return {compute_quality(*pipe.final_mesh()), *pipe.final_mesh()};
}

void expect_valid(const QualityReport& q) {
  const Validity& v = q.validity;
  EXPECT_TRUE(v.valid);
  EXPECT_EQ(v.inverted, 0u);
  EXPECT_EQ(v.zero_volume, 0u);
  EXPECT_EQ(v.unreferenced_vertices, 0u);
  EXPECT_TRUE(v.boundary.closed_manifold);
}

// 1 for each vertex on a boundary face, from the faces themselves.
std::vector<std::uint8_t> boundary_flags(const TetMesh& mesh) {
  std::vector<std::uint8_t> on(mesh.vertices.size(), 0);
  for (const Triangle& f : boundary_triangles(mesh))
    for (std::int32_t v : f) on[std::size_t(v)] = 1;
  return on;
}

}  // namespace

TEST(MeshGeneration, SphereIsABall) {
  const double R = 8.0;
  Parameters fine;
  fine.r = 0.25;  // the default 0.4 puts only ~50 samples on so small a sphere
  const PhantomMesh r = mesh_phantom(sphere_phantom({3, -2, 5}, R), fine);
  expect_valid(r.quality);
  EXPECT_EQ(r.quality.validity.boundary.euler_characteristic, 2);
  EXPECT_EQ(r.quality.validity.boundary.components, 1u);
  // All vertices of B lie on the surface, so the mesh is an inscribed polyhedron: with samples
  // r·R = 2 mm apart its chords cut ≈ 2–3 % of the volume; the smoothed surface adds ~1 %.
  const double volume = 4.0 / 3.0 * kPi * R * R * R;
  EXPECT_LT(r.quality.volume_mm3, volume);
  EXPECT_GT(r.quality.volume_mm3, 0.93 * volume);
}

TEST(MeshGeneration, TorusHasGenusOne) {
  const double major = 9.0, minor = 3.5;
  const PhantomMesh r = mesh_phantom(torus_phantom({-4, 1, 2}, major, minor));
  expect_valid(r.quality);
  EXPECT_EQ(r.quality.validity.boundary.euler_characteristic, 0);
  EXPECT_EQ(r.quality.validity.boundary.components, 1u);
  // Boundary vertices on the surface (stage 6 snaps the exposed interior ones onto it): an
  // inscribed polyhedron, whose chords cut more of the thin tube (minor radius 3.5 mm) than of
  // a ball.
  const double volume = 2 * kPi * kPi * major * minor * minor;
  EXPECT_LT(r.quality.volume_mm3, volume);
  EXPECT_GT(r.quality.volume_mm3, 0.92 * volume);
}

// By default a thick shell keeps its cavity (an eighth of the ball: too large to be a flaw of
// the segmentation), so both boundaries, each a sphere; allowed to fill it, it is a ball.
TEST(MeshGeneration, HollowSphereKeepsItsCavity) {
  const PhantomMesh r = mesh_phantom(hollow_sphere_phantom({0, 0, 0}, 5.0, 10.0));
  expect_valid(r.quality);
  EXPECT_EQ(r.quality.validity.boundary.euler_characteristic, 4);
  EXPECT_EQ(r.quality.validity.boundary.components, 2u);
  const double shell = 4.0 / 3.0 * kPi * (1000.0 - 125.0);
  EXPECT_NEAR(r.quality.volume_mm3, shell, 0.06 * shell);
  Parameters fill_all;
  fill_all.max_cavity_fraction = 1;
  const PhantomMesh filled = mesh_phantom(hollow_sphere_phantom({0, 0, 0}, 5.0, 10.0), fill_all);
  EXPECT_EQ(filled.quality.validity.boundary.euler_characteristic, 2);
  EXPECT_EQ(filled.quality.validity.boundary.components, 1u);
}

// Stage 5 counts its boundary's Euler characteristic from its cells (refinement rounds judge
// topology by it): the mesh's own faces give the same, on a ball, a torus and a shell.
TEST(MeshGeneration, BoundaryEulerCharacteristicFromTheCellsIsTheFaces) {
  for (const Phantom& p : {sphere_phantom({3, -2, 5}, 8.0), torus_phantom({-4, 1, 2}, 9.0, 3.5),
                           hollow_sphere_phantom({0, 0, 0}, 5.0, 10.0)}) {
    Pipeline pipe;
    pipe.set_image(std::make_shared<Image>(
        rasterize(p, grid_around(p, {0.6, 0.7, 0.8}, rotation_matrix({1, 2, 2}, 0.5)))));
    pipe.run_through(Stage::mesh);
    const RefinedMesh& m = *pipe.mesh();
    EXPECT_EQ(m.boundary_euler, compute_quality(m.mesh).validity.boundary.euler_characteristic)
        << p.name;
  }
}

TEST(MeshGeneration, SameInputSameMesh) {
  const Phantom p = two_spheres_phantom({0, 0, 0}, 5.0, 1.5);
  const PhantomMesh a = mesh_phantom(p), b = mesh_phantom(p);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  EXPECT_EQ(a.mesh.tets, b.mesh.tets);
  for (std::size_t i = 0; i < a.mesh.vertices.size(); ++i)
    ASSERT_TRUE(a.mesh.vertices[i] == b.mesh.vertices[i]) << i;
  expect_valid(a.quality);
  EXPECT_EQ(a.quality.validity.boundary.components, 2u);  // two spheres 1.5 mm apart
}

// Stage 5's triangulation is built by all threads, each inserting where it can lock; the
// triangulation, and every step after it, must not depend on which thread got where.
TEST(MeshGeneration, OneThreadGivesTheMeshOfAll) {
  const Phantom p = torus_phantom({-4, 1, 2}, 9.0, 3.5);
  const PhantomMesh all = mesh_phantom(p);
  PhantomMesh one;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = mesh_phantom(p);
  }
  ASSERT_EQ(all.mesh.vertices.size(), one.mesh.vertices.size());
  EXPECT_EQ(all.mesh.tets, one.mesh.tets);
  for (std::size_t i = 0; i < all.mesh.vertices.size(); ++i)
    ASSERT_TRUE(all.mesh.vertices[i] == one.mesh.vertices[i]) << i;
}

// Rule 3's fallback on its own: with no rounds of sample deletion, peeling alone must leave the
// liver's boundary (which pinches: the rounds delete samples there) a closed 2-manifold.
TEST(MeshGeneration, PeelingAloneRepairsTheLiversPinches) {
  const std::string path = CVTMESH_SOURCE_DIR "/data/liver.inr.gz";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
  Pipeline pipe;
  pipe.set_image(std::make_shared<Image>(read_image(path)));
  pipe.run_through(Stage::shallow);
  MeshGenerationOptions generation = mesh_options(pipe.parameters());
  FidelityRefinementOptions refinement = refinement_options(pipe.parameters());
  refinement.max_rounds = 0;
  auto mesh = [&] {
    return build_refined_mesh(*pipe.preprocess(), pipe.surface()->world,
                              pipe.shallow()->kept_world, generation, refinement);
  };
  const RefinedMesh rounds = mesh();
  EXPECT_FALSE(rounds.pinched_samples.empty());
  EXPECT_TRUE(rounds.repair.manifold);
  // The boundary vertices the mesher reports, from its cells (after rule 4 dropped the
  // specks) or, once it peeled, from the faces: the same as the mesh's own faces say.
  EXPECT_GT(rounds.removed_small_components, 0u);
  EXPECT_TRUE(rounds.on_boundary == boundary_flags(rounds.mesh));
  EXPECT_EQ(rounds.boundary_euler,
            compute_quality(rounds.mesh).validity.boundary.euler_characteristic);
  generation.max_pinch_passes = 0;
  const RefinedMesh peeled = mesh();
  EXPECT_TRUE(peeled.pinched_samples.empty());
  EXPECT_GT(peeled.repair.edge_fans_removed + peeled.repair.vertex_fans_removed, 0u);
  EXPECT_TRUE(peeled.repair.manifold);
  EXPECT_TRUE(peeled.on_boundary == boundary_flags(peeled.mesh));
  const QualityReport q = compute_quality(peeled.mesh);
  expect_valid(q);
  EXPECT_EQ(peeled.boundary_euler, q.validity.boundary.euler_characteristic);
  EXPECT_EQ(q.validity.boundary.components,
            compute_quality(rounds.mesh).validity.boundary.components);
}

namespace {

// n points spread over the sphere |p| = R (a Fibonacci spiral, turned by `phase`).
std::vector<Vec3> sphere_points(int n, double R, double phase) {
  std::vector<Vec3> out;
  for (int k = 0; k < n; ++k) {
    const double z = 1 - (2 * k + 1.0) / n, rho = std::sqrt(1 - z * z);
    const double a = k * kPi * (3 - std::sqrt(5.0)) + phase;
    out.push_back(Vec3{rho * std::cos(a), rho * std::sin(a), z} * R);
  }
  return out;
}

}  // namespace

TEST(DelaunayMesher, RefiningGivesTheMeshOfTheRefinedSamples) {
  const double R = 10;
  std::vector<Vec3> surface = sphere_points(500, R, 0), interior;
  for (double x = -8; x <= 8; x += 1.7)
    for (double y = -8; y <= 8; y += 1.7)
      for (double z = -8; z <= 8; z += 1.7)
        if (norm(Vec3{x, y, z}) < R - 1.5) interior.push_back({x, y, z});
  const OccupancyFunction occupancy = [&](const Vec3& p) {
    return std::clamp(0.5 - (norm(p) - R) / 2, 0.0, 1.0);
  };
  MeshGenerationOptions options;
  options.interior_jitter_mm = 0;  // the same positions whichever way the samples are indexed
  DelaunayMesher mesher(surface, interior, occupancy, options);
  const MeshGenerationResult first = mesher.mesh();
  expect_valid(compute_quality(first.mesh));

  // 60 more surface samples; interior samples with x > 4 and the first three are dropped.
  const std::vector<Vec3> added = sphere_points(60, R, 0.7);
  std::vector<int> dropped;
  std::vector<Vec3> kept;
  for (std::size_t i = 0; i < interior.size(); ++i)
    if (i < 3 || interior[i].x > 4)
      dropped.push_back(int(i));
    else
      kept.push_back(interior[i]);
  ASSERT_GT(dropped.size(), 20u);
  mesher.refine(added, dropped, {});
  const MeshGenerationResult refined = mesher.mesh();
  expect_valid(compute_quality(refined.mesh));

  std::vector<Vec3> all_surface = surface;
  all_surface.insert(all_surface.end(), added.begin(), added.end());
  const MeshGenerationResult fresh = build_delaunay_mesh(all_surface, kept, occupancy, options);
  EXPECT_EQ(refined.mesh.vertices, fresh.mesh.vertices);
  EXPECT_EQ(refined.mesh.tets, fresh.mesh.tets);
  EXPECT_EQ(refined.vertex_source, fresh.vertex_source);
  EXPECT_EQ(refined.exterior_poles.size(), fresh.exterior_poles.size());
  EXPECT_GT(refined.mesh.vertices.size(), first.mesh.vertices.size() + 60 - dropped.size() - 5);
}

TEST(DelaunayMesher, ABoxSampledOnAGridIsExactlyTheBox) {
  // Four samples of a face square are coplanar and cocircular, and the interior grid is
  // cospherical throughout: Delaunay has flat cells, none of which may stay in the mesh.
  const double h = 1.0;
  const int n = 8;  // the box is [0, 8]³
  std::vector<Vec3> surface, interior;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      for (int k = 0; k <= n; ++k) {
        const bool face = i == 0 || j == 0 || k == 0 || i == n || j == n || k == n;
        if (face) surface.push_back(Vec3{double(i), double(j), double(k)} * h);
        else if (i % 2 == 0 && j % 2 == 0 && k % 2 == 0) interior.push_back(Vec3{double(i), double(j), double(k)} * h);
      }
  const OccupancyFunction occupancy = [&](const Vec3& p) {
    const double out = std::max({-p.x, -p.y, -p.z, p.x - n * h, p.y - n * h, p.z - n * h});
    return std::clamp(0.5 - out, 0.0, 1.0);
  };
  const MeshGenerationResult r = build_delaunay_mesh(surface, interior, occupancy);
  const QualityReport q = compute_quality(r.mesh);
  expect_valid(q);
  EXPECT_EQ(q.validity.boundary.euler_characteristic, 2);
  EXPECT_TRUE(r.repair.manifold);
  EXPECT_NEAR(q.volume_mm3, n * n * n * h * h * h, 1e-6);
}

TEST(DelaunayMesher, RefiningAwayEveryInteriorSampleLeavesASurfaceOnlyMesh) {
  const double R = 10;
  const std::vector<Vec3> surface = sphere_points(300, R, 0), added = sphere_points(40, R, 0.7);
  const std::vector<Vec3> interior = {{0, 0, 0}, {2, 1, 0}, {-1, 3, 2}};
  const OccupancyFunction occupancy = [&](const Vec3& p) {
    return std::clamp(0.5 - (norm(p) - R) / 2, 0.0, 1.0);
  };
  for (const bool with_interior : {true, false}) {
    DelaunayMesher mesher(surface, with_interior ? interior : std::vector<Vec3>{}, occupancy);
    mesher.mesh();
    mesher.refine(added, with_interior ? std::vector<int>{0, 1, 2} : std::vector<int>{}, {});
    const MeshGenerationResult r = mesher.mesh();
    expect_valid(compute_quality(r.mesh));
    ASSERT_EQ(r.vertex_source.size(), r.mesh.vertices.size());
    for (std::size_t v = 0; v < r.mesh.vertices.size(); ++v) {
      ASSERT_LT(r.vertex_source[v], 340);  // B and the added samples only
      const Vec3& sample = r.vertex_source[v] < 300 ? surface[std::size_t(r.vertex_source[v])]
                                                    : added[std::size_t(r.vertex_source[v] - 300)];
      EXPECT_EQ(r.mesh.vertices[v], sample);
    }
    EXPECT_THROW(mesher.refine({}, {7}, {}), std::out_of_range);  // no interior sample 7
  }
}
