// Stage 7: the mask's marching-cubes surface, volume error and surface distances.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "evaluate/fidelity.h"
#include "evaluate/quality.h"
#include "fields/marching_cubes.h"
#include "phantoms.h"

using namespace cvt;

namespace {

const Vec3 kSpacing{0.7, 0.8, 1.1};
const double kPi = 3.14159265358979323846;

Mask phantom_mask(const Phantom& p, const Vec3& spacing = kSpacing) {
  const Image image = rasterize(p, grid_around(p, spacing, rotation_matrix({1, 2, 0.5}, 0.6)));
  Mask mask(image.grid());
  for (std::size_t i = 0; i < mask.size(); ++i) mask.data[i] = image.voxels.data[i] > 0.5f;
  return mask;
}

// Volume enclosed by a closed, outward-oriented surface (divergence theorem).
double enclosed_volume(const TriangleSurface& s) {
  double v = 0;
  for (const Triangle& t : s.triangles)
    v += dot(s.vertices[t[0]], cross(s.vertices[t[1]], s.vertices[t[2]])) / 6;
  return v;
}

double half_voxel_diagonal(const Vec3& s) {
  return 0.5 * norm(s);
}

// Vertices that some triangle uses.
std::size_t used_vertices(const TriangleSurface& s) {
  std::vector<char> used(s.vertices.size(), 0);
  for (const Triangle& t : s.triangles)
    for (std::int32_t v : t) used[std::size_t(v)] = 1;
  return std::size_t(std::count(used.begin(), used.end(), 1));
}

}  // namespace

TEST(MarchingCubes, ClosedManifoldWithThePhantomsTopology) {
  struct Case {
    Phantom phantom;
    long long euler;
    std::size_t components;
  };
  const Case cases[] = {{sphere_phantom({3, -2, 5}, 6.0), 2, 1},
                        {torus_phantom({1, 2, 3}, 8.0, 3.0), 0, 1},
                        {hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0), 4, 2}};
  for (const Case& c : cases) {
    const Mask mask = phantom_mask(c.phantom);
    const TriangleSurface s = marching_cubes(mask);
    const SurfaceTopology topo = surface_topology(s.triangles, s.vertices.size());
    EXPECT_TRUE(topo.closed_manifold) << c.phantom.name;
    EXPECT_EQ(topo.euler_characteristic, c.euler) << c.phantom.name;
    EXPECT_EQ(topo.components, c.components) << c.phantom.name;
    // Outward oriented, and a little inside the voxels' staircase volume.
    const double voxels = double(std::count(mask.data.begin(), mask.data.end(), 1)) * kSpacing.x *
                          kSpacing.y * kSpacing.z;
    const double volume = enclosed_volume(s);
    EXPECT_GT(volume, 0.8 * voxels) << c.phantom.name;
    EXPECT_LT(volume, voxels) << c.phantom.name;
  }
}

TEST(MarchingCubes, ObjectTouchingTheGridBorderIsClosed) {
  Grid g;
  g.dims = {3, 4, 2};
  Mask full(g, 1);
  const TriangleSurface s = marching_cubes(full);
  const SurfaceTopology topo = surface_topology(s.triangles, s.vertices.size());
  EXPECT_TRUE(topo.closed_manifold);
  EXPECT_EQ(topo.euler_characteristic, 2);
  // The box of voxel centres grown by half a voxel, minus its cut corners and edges.
  EXPECT_GT(enclosed_volume(s), 2.0 * 3 * 1);
}

// Noise exercises every ambiguous configuration: still closed and manifold.
TEST(MarchingCubes, RandomMasksGiveClosedManifolds) {
  Grid g;
  g.dims = {18, 17, 16};
  g.spacing = {0.7, 0.8, 1.1};
  std::mt19937 rng(11);
  for (double density : {0.2, 0.5, 0.8}) {
    Mask mask(g, 0);
    std::bernoulli_distribution in(density);
    for (unsigned char& v : mask.data) v = in(rng);
    const TriangleSurface s = marching_cubes(mask);
    const SurfaceTopology topo = surface_topology(s.triangles, s.vertices.size());
    EXPECT_TRUE(topo.closed_manifold) << density;
    EXPECT_GT(enclosed_volume(s), 0) << density;
  }
}

// Ambiguous faces keep inside corners apart: voxels touching along an edge or at a corner give
// separate spheres; voxels sharing a face give one.
TEST(MarchingCubes, DiagonalVoxelsStayApart) {
  Grid g;
  g.dims = {4, 4, 4};
  const std::array<std::array<int, 3>, 3> second = {{{2, 2, 1}, {2, 2, 2}, {2, 1, 1}}};
  const long long euler[3] = {4, 4, 2};
  for (int c = 0; c < 3; ++c) {
    Mask mask(g, 0);
    mask.at(1, 1, 1) = 1;
    mask.at(second[c][0], second[c][1], second[c][2]) = 1;
    const TriangleSurface s = marching_cubes(mask);
    const SurfaceTopology topo = surface_topology(s.triangles, s.vertices.size());
    EXPECT_TRUE(topo.closed_manifold) << c;
    EXPECT_EQ(topo.euler_characteristic, euler[c]) << c;
    EXPECT_EQ(topo.components, std::size_t(euler[c] / 2)) << c;
  }
}

TEST(Fidelity, SingleVoxelCubeAgainstItsOctahedron) {
  Grid g;
  g.dims = {3, 3, 3};
  g.spacing = {0.8, 1.0, 1.2};
  g.origin = {10, -3, 2};
  g.direction = rotation_matrix({0.3, 1, -0.2}, 0.9);
  Mask mask(g, 0);
  mask.at(1, 1, 1) = 1;
  const FidelityReport rep = compute_fidelity(voxel_tet_mesh(mask), mask);
  EXPECT_NEAR(rep.volume_error_percent, 0, 1e-9);
  // The farthest point is a cube corner, at 2 / √(Σ 1/a²) (a = half spacings) from the face
  // x/a + y/b + z/c = 1 of the octahedron (the foot of the perpendicular lies inside the face
  // for these spacings: the corner minus 2 (1/a, 1/b, 1/c) / Σ 1/a² has positive coordinates).
  const Vec3 a = g.spacing * 0.5;
  const double corner = 2 / std::sqrt(1 / (a.x * a.x) + 1 / (a.y * a.y) + 1 / (a.z * a.z));
  EXPECT_NEAR(rep.distance.a_to_b_max_mm, corner, 1e-9);
  EXPECT_NEAR(rep.distance.hausdorff_mm, corner, 1e-9);
  EXPECT_LT(rep.distance.b_to_a_max_mm, corner);
  // ... and the report says where: at one of the cube's corners, voxel index 1 ± ½ on each axis.
  const Vec3 at = g.world_to_index(rep.distance.a_to_b_max_at);
  for (double c : {at.x, at.y, at.z})
    EXPECT_NEAR(std::abs(c - 1.0), 0.5, 1e-9) << at.x << " " << at.y << " " << at.z;
  const nlohmann::json j = to_json(rep);
  EXPECT_EQ(j["mesh_to_object"]["max_at_mm"][1], rep.distance.a_to_b_max_at.y);
}

// Every point of the voxel surface is within half a face diagonal of a marching-cubes vertex
// (the centre of its face); every marching-cubes point lies in a cube of eight voxel centres
// whose states are mixed, so the common corner of those eight voxels is on the voxel surface and
// within half a voxel diagonal. Hence Hausdorff ≤ half a voxel diagonal.
TEST(Fidelity, VoxelMeshAgainstItsOwnMask) {
  for (const Phantom& p : {sphere_phantom({3, -2, 5}, 6.0), torus_phantom({1, 2, 3}, 8.0, 3.0)}) {
    const Mask mask = phantom_mask(p);
    const TetMesh mesh = voxel_tet_mesh(mask);
    const FidelityReport rep = compute_fidelity(mesh, mask);
    EXPECT_NEAR(rep.volume_error_percent, 0, 1e-9) << p.name;
    EXPECT_LE(rep.distance.hausdorff_mm, half_voxel_diagonal(kSpacing)) << p.name;
    EXPECT_GT(rep.distance.hausdorff_mm, 0.3) << p.name;
    EXPECT_GT(rep.distance.mean_mm, 0) << p.name;
    EXPECT_LT(rep.distance.mean_mm, 0.25 * kSpacing.z) << p.name;
    EXPECT_LE(rep.distance.mean_mm, rep.distance.p95_mm) << p.name;
    EXPECT_LE(rep.distance.p95_mm, rep.distance.hausdorff_mm) << p.name;
    const nlohmann::json j = to_json(rep);
    EXPECT_TRUE(j.contains("hausdorff_mm") && j.contains("volume_error_percent"));
    EXPECT_EQ(j["mesh_to_object"]["max_mm"], rep.distance.a_to_b_max_mm);
  }
}

TEST(Fidelity, ScaledMeshHasTheCubedVolumeError) {
  const Mask mask = phantom_mask(sphere_phantom({0, 0, 0}, 5.0));
  TetMesh mesh = voxel_tet_mesh(mask);
  for (Vec3& v : mesh.vertices) v = v * 1.02;  // the world origin is the sphere's centre
  const FidelityReport rep = compute_fidelity(mesh, mask);
  EXPECT_NEAR(rep.volume_error_percent, 100 * (1.02 * 1.02 * 1.02 - 1), 1e-9);
}

TEST(SurfaceDistance, ZeroAgainstItselfAndTheTranslationWhenMoved) {
  const TetMesh mesh = voxel_tet_mesh(phantom_mask(sphere_phantom({3, -2, 5}, 5.0)));
  const SurfaceDistance self = surface_distance(mesh, mesh);
  EXPECT_NEAR(self.hausdorff_mm, 0, 1e-12);  // point–triangle distances round to ~1e-15
  EXPECT_NEAR(self.mean_mm, 0, 1e-12);
  EXPECT_NEAR(self.p95_mm, 0, 1e-12);
  EXPECT_GT(self.samples_a, 1000u);

  // The extreme vertex of the convex hull in the direction t moves |t| away from everything;
  // nothing moves farther.
  const Vec3 t{0.3, -0.2, 0.45};
  TetMesh moved = mesh;
  for (Vec3& v : moved.vertices) v += t;
  const SurfaceDistance d = surface_distance(mesh, moved);
  EXPECT_NEAR(d.hausdorff_mm, norm(t), 1e-9);
  EXPECT_NEAR(d.a_to_b_max_mm, norm(t), 1e-9);
  EXPECT_NEAR(d.b_to_a_max_mm, norm(t), 1e-9);
  EXPECT_GT(d.mean_mm, 0);
  EXPECT_LT(d.mean_mm, norm(t));
}

// A large object at CT spacing (a torus 80 mm across, 0.6 × 0.6 × 1.3 mm voxels), its voxel mesh
// against its own mask: at the default sample spacing (two smallest voxel spacings), and under a
// sample cap that forces a coarser spacing. The object volume is the torus's, the object
// surface has its topology, and the Hausdorff bound above holds at both spacings.
TEST(Fidelity, LargeObjectAtCtSpacingAndUnderASampleCap) {
  const Vec3 ct{0.6, 0.6, 1.3};
  const double major = 30, minor = 10;
  const Mask mask = phantom_mask(torus_phantom({0, 0, 0}, major, minor), ct);
  const TetMesh mesh = voxel_tet_mesh(mask);
  const FidelityReport fine = compute_fidelity(mesh, mask);
  const double torus_volume = 2 * kPi * kPi * major * minor * minor;
  EXPECT_NEAR(fine.object_volume_mm3, torus_volume, 0.01 * torus_volume);
  EXPECT_NEAR(fine.volume_error_percent, 0, 1e-7);  // rounding over many tets
  EXPECT_EQ(fine.object_surface_euler, 0);
  EXPECT_EQ(fine.object_surface_components, 1u);
  EXPECT_DOUBLE_EQ(fine.distance.sample_spacing_mm, 1.2);  // two smallest voxel spacings
  EXPECT_LE(fine.distance.hausdorff_mm, half_voxel_diagonal(ct));
  EXPECT_GT(fine.distance.mean_mm, 0);
  EXPECT_LT(fine.distance.mean_mm, 0.25 * ct.z);

  // The samples stay below a cap on both surfaces; the spacing grows to keep them there, and the
  // figures stay within the same bounds.
  FidelityOptions capped_options;
  capped_options.max_samples = std::max(fine.distance.samples_a, fine.distance.samples_b) / 2;
  const FidelityReport capped = compute_fidelity(mesh, mask, capped_options);
  EXPECT_GT(capped.distance.sample_spacing_mm, 1.2);
  EXPECT_LE(capped.distance.samples_a, capped_options.max_samples);
  EXPECT_LE(capped.distance.samples_b, capped_options.max_samples);
  EXPECT_EQ(capped.volume_error_percent, fine.volume_error_percent);
  EXPECT_LE(capped.distance.hausdorff_mm, half_voxel_diagonal(ct));
  // Coarser samples on a staircase against its marching-cubes surface (the distance varies most
  // within a voxel there) move the mean a little.
  EXPECT_NEAR(capped.distance.mean_mm, fine.distance.mean_mm, 0.2 * fine.distance.mean_mm);
}
