// Fidelity refinement of stage 5: voxelising a mesh, finding where mesh and object disagree,
// and the refined mesh of a block with a narrow slot (the liver's thin channels in miniature).
#include <gtest/gtest.h>

#include <random>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <tuple>
#include <utility>

#include "evaluate/fidelity.h"
#include "meshing/fidelity_refinement.h"
#include "phantoms.h"
#include "pipeline/pipeline.h"
#include "evaluate/quality.h"
#include "fields/smoothing.h"

using namespace cvt;

namespace {

// A box |x| ≤ 10, |y| ≤ 10, |z| ≤ 7 mm with a slot |x| < width/2, z > 7 − depth cut from the
// top through the whole y extent (genus 0 either way). Sign-exact CSG distance.
Phantom slotted_block(double width_mm, double depth_mm) {
  Phantom p;
  p.name = "slotted block";
  p.center = {0, 0, 0};
  p.radius = std::sqrt(10.0 * 10 + 10 * 10 + 7 * 7);
  p.signed_distance = [=](const Vec3& w) {
    const double box = std::max({std::abs(w.x) - 10, std::abs(w.y) - 10, std::abs(w.z) - 7});
    const double slot = std::max(std::abs(w.x) - width_mm / 2, (7 - depth_mm) - w.z);
    return std::max(box, -slot);
  };
  return p;
}

Image slotted_image() {
  const Phantom p = slotted_block(1.25, 9.0);
  return rasterize(p, grid_around(p, {0.6, 0.6, 1.3}, {1, 0, 0, 0, 1, 0, 0, 0, 1}));
}

struct SlotRun {
  RefinedMesh refined;  // stage 5, with the refinement record
  TetMesh mesh;         // the final mesh (stage 6 on)
  QualityReport quality;
  FidelityReport fidelity;
};

SlotRun run(const Image& image, int rounds, std::uint64_t seed = 1) {
  Pipeline pipe;
  pipe.set_image(std::make_shared<Image>(image));
  Parameters params;
  params.seed = seed;
  params.fidelity_rounds = rounds;
  pipe.set_parameters(params);
  pipe.run_through(Stage::optimize);
  return {*pipe.mesh(), *pipe.final_mesh(), compute_quality(*pipe.final_mesh()),
          compute_fidelity(*pipe.final_mesh(), pipe.preprocess()->object)};
}

}  // namespace

TEST(Voxelize, SingleTetCoversExactlyTheCentresInside) {
  Grid g;
  g.dims = {6, 6, 6};
  g.spacing = {0.5, 1.0, 2.0};
  g.origin = {-1, 2, 3};
  TetMesh m;
  // The corner tet x/0.5 + y + z/2 ≤ 4 (in index units i + j + k ≤ 4) of the grid's first octant.
  m.vertices = {g.index_to_world({0, 0, 0}), g.index_to_world({4, 0, 0}),
                g.index_to_world({0, 4, 0}), g.index_to_world({0, 0, 4})};
  m.tets = {{0, 1, 2, 3}};
  const Mask inside = voxelize(m, g);
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i) EXPECT_EQ(inside.at(i, j, k), i + j + k <= 4 ? 1 : 0) << i << j << k;
}

// Random tets on a rotated, anisotropic grid: every voxel centre is inside exactly when its
// barycentric coordinates (solved here with Cramer's rule in world space) are all ≥ 0; centres
// within 1e-6 of a face may go either way.
TEST(Voxelize, RandomTetsAgreeWithBarycentricCoordinates) {
  Grid g;
  g.dims = {24, 20, 16};
  g.spacing = {0.6, 0.7, 1.3};
  g.origin = {5, -4, 2};
  g.direction = rotation_matrix({1, 2, 0.5}, 0.7);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 26);
  std::size_t inside_count = 0;
  for (int trial = 0; trial < 300; ++trial) {
    TetMesh m;
    for (int k = 0; k < 4; ++k) m.vertices.push_back(g.index_to_world({u(rng), u(rng) * 0.8, u(rng) * 0.6}));
    m.tets = {{0, 1, 2, 3}};
    const Vec3 a = m.vertices[0], e1 = m.vertices[1] - a, e2 = m.vertices[2] - a, e3 = m.vertices[3] - a;
    const double det = dot(e1, cross(e2, e3));
    if (std::abs(det) < 1e-3) continue;
    const Mask inside = voxelize(m, g);
    for (int k = 0; k < g.dims[2]; ++k)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int i = 0; i < g.dims[0]; ++i) {
          const Vec3 p = g.index_to_world({double(i), double(j), double(k)}) - a;
          const double b1 = dot(p, cross(e2, e3)) / det, b2 = dot(e1, cross(p, e3)) / det,
                       b3 = dot(e1, cross(e2, p)) / det, b0 = 1 - b1 - b2 - b3;
          const double margin = std::min({b0, b1, b2, b3});
          if (std::abs(margin) < 1e-6) continue;
          ASSERT_EQ(inside.at(i, j, k), margin > 0 ? 1 : 0) << trial << ": " << i << " " << j << " " << k;
          inside_count += margin > 0;
        }
  }
  EXPECT_GT(inside_count, 10000u);  // the tets do cover voxels
}

namespace {

// A jittered lattice of (n+1)³ points over a grid, and its cubes as tets: Kuhn's six around the
// main diagonal, or twelve from a new point at the centre (ids from the lattice's count on).
struct LatticeMesh {
  Grid grid;
  int n = 0;
  std::vector<Vec3> points;  // by id
  std::vector<std::array<std::int32_t, 4>> tets;

  std::int32_t id(int i, int j, int k) const { return (k * (n + 1) + j) * (n + 1) + i; }
  void kuhn(int i, int j, int k) {
    const int axes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (const auto& a : axes) {
      int at[3] = {i, j, k};
      std::array<std::int32_t, 4> t;
      t[0] = id(at[0], at[1], at[2]);
      for (int s = 0; s < 3; ++s) {
        ++at[a[s]];
        t[s + 1] = id(at[0], at[1], at[2]);
      }
      tets.push_back(t);
    }
  }
  void star(int i, int j, int k) {
    points.push_back(grid.index_to_world({i + 0.5, j + 0.45, k + 0.55}));
    const std::int32_t c = std::int32_t(points.size() - 1);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        int q[4][3];
        for (int m = 0; m < 4; ++m) {
          q[m][axis] = side;
          q[m][(axis + 1) % 3] = (m == 1 || m == 2);
          q[m][(axis + 2) % 3] = (m >= 2);
        }
        auto v = [&](int m) { return id(i + q[m][0], j + q[m][1], k + q[m][2]); };
        tets.push_back({c, v(0), v(1), v(2)});
        tets.push_back({c, v(0), v(2), v(3)});
      }
  }
  // The mesh with its vertices in a shuffled order (as a refined mesh renumbers them), and
  // the id of each.
  std::pair<TetMesh, std::vector<std::int32_t>> shuffled(std::mt19937& rng) const {
    std::vector<std::int32_t> ids(points.size());
    for (std::size_t v = 0; v < ids.size(); ++v) ids[v] = std::int32_t(v);
    std::shuffle(ids.begin(), ids.end(), rng);
    std::vector<std::int32_t> index_of(points.size());
    TetMesh m;
    for (std::size_t v = 0; v < ids.size(); ++v) {
      index_of[std::size_t(ids[v])] = std::int32_t(v);
      m.vertices.push_back(points[std::size_t(ids[v])]);
    }
    for (const auto& t : tets) {
      const int r = int(rng() % 4);  // the corners in another even order
      const Tet mapped = {index_of[t[0]], index_of[t[1]], index_of[t[2]], index_of[t[3]]};
      static const int even[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
      m.tets.push_back({mapped[even[r][0]], mapped[even[r][1]], mapped[even[r][2]], mapped[even[r][3]]});
    }
    std::shuffle(m.tets.begin(), m.tets.end(), rng);
    return {m, ids};
  }
};

}  // namespace

// Three meshes of a lattice, each changing the last in places (cubes split from a new centre
// point, cubes removed, cubes back to Kuhn's split) with its vertices renumbered: every update
// gives exactly voxelize()'s voxels.
TEST(IncrementalVoxelizer, EveryUpdateEqualsVoxelizingTheWholeMesh) {
  Grid g;
  g.dims = {40, 36, 22};
  g.spacing = {0.6, 0.7, 1.3};
  g.origin = {5, -4, 2};
  g.direction = rotation_matrix({1, 2, 0.5}, 0.7);
  LatticeMesh lattice;
  lattice.n = 6;
  lattice.grid = g;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.8, 0.8);
  for (int k = 0; k <= lattice.n; ++k)
    for (int j = 0; j <= lattice.n; ++j)
      for (int i = 0; i <= lattice.n; ++i)  // cubes of ~5 voxels, the lattice inside the grid
        lattice.points.push_back(g.index_to_world(
            {2 + 5.5 * i + jitter(rng), 2 + 5 * j + jitter(rng), 1 + 3 * k + jitter(rng) / 2}));
  const auto cubes = [&](auto split_of) {
    lattice.tets.clear();
    for (int k = 0; k < lattice.n; ++k)
      for (int j = 0; j < lattice.n; ++j)
        for (int i = 0; i < lattice.n; ++i) {
          const char split = split_of(i, j, k);
          if (split == 'k') lattice.kuhn(i, j, k);
          if (split == 's') lattice.star(i, j, k);
        }
  };
  IncrementalVoxelizer voxels(g);
  std::vector<Mask> results;
  const auto check = [&](const char* step) {
    const auto [mesh, ids] = lattice.shuffled(rng);
    const Mask expected = voxelize(mesh, g);
    const Mask got = voxels.update(mesh, ids);
    EXPECT_EQ(got.data, expected.data) << step;
    results.push_back(got);
  };
  cubes([](int, int, int) { return 'k'; });
  check("all Kuhn");
  cubes([](int i, int j, int k) { return i < 2 && j < 3 ? 's' : i == 4 && k >= 3 ? '-' : 'k'; });
  check("split from centres, a slab removed");
  cubes([](int i, int j, int k) { return i >= 3 && j == 5 ? 's' : i == 4 && k >= 3 ? '-' : 'k'; });
  check("others split, the first back to Kuhn");
  // The removed slab is empty; the lattice covers voxels.
  EXPECT_NE(results[0].data, results[1].data);
  EXPECT_GT(std::count(results[2].data.begin(), results[2].data.end(), 1), 10000);
}

TEST(FidelityFix, NothingWhereMeshAndObjectAgree) {
  const Image image = slotted_image();
  Pipeline pipe;
  pipe.set_image(std::make_shared<Image>(image));
  pipe.run_through(Stage::preprocess);
  const PreprocessResult& pre = *pipe.preprocess();
  const FidelityFix fix = find_fidelity_fix(pre.object, pre, {}, 1.0, 0.5);
  EXPECT_EQ(fix.disagreeing_voxels, 0u);
  EXPECT_TRUE(fix.samples.empty());
  EXPECT_TRUE(fix.outside_points.empty());
}

TEST(FidelityFix, AFilledSlotGetsSamplesOnItsWallsAndOutsidePointsInside) {
  const Image image = slotted_image();
  Pipeline pipe;
  pipe.set_image(std::make_shared<Image>(image));
  pipe.run_through(Stage::preprocess);
  const PreprocessResult& pre = *pipe.preprocess();
  // A "mesh" that bridges the slot: the object with the slot filled.
  Mask bridged = pre.object;
  const Grid& g = bridged.grid;
  for (std::size_t v = 0; v < bridged.size(); ++v) {
    const Vec3 w = g.voxel_to_world(v);
    if (std::abs(w.x) < 0.7 && std::abs(w.y) <= 10 && w.z > -2 && w.z <= 7) bridged.data[v] = 1;
  }
  const double spacing = 0.5;
  const FidelityFix fix = find_fidelity_fix(bridged, pre, {}, 2.0, spacing);
  EXPECT_GT(fix.disagreeing_voxels, 0u);
  ASSERT_GT(fix.samples.size(), 10u);
  ASSERT_GT(fix.outside_points.size(), 0u);
  for (const Vec3& s : fix.samples) {
    // On the slot's walls (x = ±0.625, smoothed) and inside its depth, on the 0.5 level.
    EXPECT_NEAR(std::abs(s.x), 0.625, 0.35) << s.x << " " << s.y << " " << s.z;
    EXPECT_GT(s.z, -2.5);
    EXPECT_NEAR(sample_trilinear(pre.indicator, g.world_to_index(s)), 0.5, 1e-3);
  }
  for (std::size_t a = 0; a < fix.samples.size(); ++a)
    for (std::size_t b = a + 1; b < fix.samples.size(); ++b)
      EXPECT_GE(distance(fix.samples[a], fix.samples[b]), spacing);
  for (const Vec3& p : fix.outside_points) EXPECT_LT(std::abs(p.x), 0.7);
}

TEST(FidelityFix, AnInteriorSampleDeepOnTheBoundaryGetsASampleWhereTheObjectEnds) {
  // The bottom of a pit too narrow for a voxel centre: only the exposed interior sample shows it.
  const Image image = slotted_image();
  Pipeline pipe;
  pipe.set_image(std::make_shared<Image>(image));
  pipe.run_through(Stage::preprocess);
  const PreprocessResult& pre = *pipe.preprocess();
  // 0.5 mm above the bottom face z = −7 (its voxel is within the 2 mm tolerance: voxel
  // distances are 1.3 mm, 2.6 mm, ... there), 3 mm above it, and in the slot (outside).
  const std::vector<Vec3> exposed = {{-6, 0, -6.5}, {-6, 0, -4}, {0, 0, 5}};
  const FidelityFix fix = find_fidelity_fix(pre.object, pre, {}, 2.0, 0.5, {}, exposed);
  EXPECT_EQ(fix.disagreeing_voxels, 0u);
  EXPECT_EQ(fix.deep_boundary, std::vector<std::size_t>{1});
  ASSERT_EQ(fix.samples.size(), 1u);
  const Vec3& s = fix.samples[0];  // on the bottom face below it, on the 0.5 level
  EXPECT_NEAR(s.z, -7, 0.7) << s.x << " " << s.y << " " << s.z;
  EXPECT_NEAR(s.x, -6, 0.7);
  EXPECT_NEAR(s.y, 0, 0.7);
  EXPECT_NEAR(sample_trilinear(pre.indicator, pre.object.grid.world_to_index(s)), 0.5, 1e-3);
}

TEST(FidelityRefinement, NarrowSlotOverSeeds) {
  // A slot two voxels wide is a coin toss for stage 5. Depending on the seed the first mesh
  // bridges parts of it, or carves dents beside it (interior samples 2.4–3.6 mm deep on the
  // boundary), and a round that fixes those can expose the next samples in turn, so that it is
  // dropped. Refinement helps some seeds a lot and leaves most alone, and it can even raise the
  // Hausdorff distance of one (fewer pits and disagreeing voxels, but a dent beside the slot's
  // top edge that neither counts); which seeds it helps moves with the rounding of the distance
  // transform. So this asks, seed by seed, what refinement guarantees, and over the seeds that
  // it helps.
  const Image image = slotted_image();
  double plain_sum = 0, refined_sum = 0;
  int improved = 0, earlier_returned = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const SlotRun plain = run(image, 0, seed), refined = run(image, 3, seed);
    for (const SlotRun* r : {&plain, &refined}) {
      EXPECT_TRUE(r->quality.validity.valid);
      EXPECT_TRUE(r->quality.validity.boundary.closed_manifold);
    }
    EXPECT_TRUE(plain.refined.refinement.empty());
    const auto& rounds = refined.refined.refinement;
    ASSERT_GE(rounds.size(), 1u);
    // Every check after the first is of a kept round's mesh: fewer pits, or as many pits and
    // fewer disagreeing voxels than the check before.
    for (std::size_t k = 1; k < rounds.size(); ++k) {
      EXPECT_TRUE(rounds[k - 1].accepted);
      EXPECT_LT(std::pair(rounds[k].deep_boundary_samples, rounds[k].disagreeing_voxels),
                std::pair(rounds[k - 1].deep_boundary_samples, rounds[k - 1].disagreeing_voxels));
    }
    // One checked mesh is returned: the nearest to the object's topology, then with the fewest
    // pits, then disagreeing voxels; what was added and dropped is what led to it.
    const long long object_euler = refined.fidelity.object_surface_euler;
    const auto rank = [&](const FidelityRefinementRound& r) {
      return std::tuple(std::llabs(r.boundary_euler - object_euler), r.deep_boundary_samples,
                        r.disagreeing_voxels);
    };
    std::size_t returned = rounds.size(), added = 0, dropped = 0;
    for (std::size_t k = 0; k < rounds.size(); ++k)
      if (rounds[k].returned) {
        EXPECT_EQ(returned, rounds.size()) << "a second returned check";
        returned = k;
      }
    ASSERT_LT(returned, rounds.size());
    for (std::size_t k = 0; k < rounds.size(); ++k) {
      EXPECT_LE(rank(rounds[returned]), rank(rounds[k])) << "check " << k;
      if (k < returned) {
        added += rounds[k].added_samples;
        dropped += rounds[k].dropped_interior;
      }
    }
    EXPECT_EQ(refined.refined.boundary_euler, rounds[returned].boundary_euler);
    EXPECT_EQ(refined.quality.validity.boundary.euler_characteristic, rounds[returned].boundary_euler);
    EXPECT_EQ(refined.refined.added_surface_samples.size(), added);
    EXPECT_EQ(refined.refined.dropped_interior_samples.size(), dropped);
    if (returned + 1 < rounds.size()) ++earlier_returned;
    // Without a kept round nothing was added, and the mesh is the first mesh.
    if (!rounds[0].accepted) {
      EXPECT_TRUE(refined.refined.added_surface_samples.empty());
      EXPECT_EQ(refined.mesh.tets, plain.mesh.tets);
    }
    plain_sum += plain.fidelity.distance.hausdorff_mm;
    refined_sum += refined.fidelity.distance.hausdorff_mm;
    improved += refined.fidelity.distance.hausdorff_mm < 0.8 * plain.fidelity.distance.hausdorff_mm;
  }
  // Over the seeds, closer to the object: the Hausdorff distances' sum drops by 5 % or more.
  EXPECT_LT(refined_sum, 0.95 * plain_sum);
  EXPECT_GE(improved, 1);
  // Some seed's last round bridges the slot where an earlier mesh did not: the rule above
  // must have been exercised.
  EXPECT_GE(earlier_returned, 1);
}

TEST(FidelityRefinement, SameInputSameMesh) {
  const Image image = slotted_image();
  const SlotRun a = run(image, 1), b = run(image, 1);
  EXPECT_EQ(a.mesh.tets, b.mesh.tets);
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  for (std::size_t v = 0; v < a.mesh.vertices.size(); ++v)
    EXPECT_EQ(distance(a.mesh.vertices[v], b.mesh.vertices[v]), 0.0);
}
