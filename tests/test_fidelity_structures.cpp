// The pieces of the fidelity evaluation: marching cubes by its table of ITK's cases against one
// ITK run, exact point–triangle distances and the triangle grid against brute force, and the
// distance samples.
#include <gtest/gtest.h>
#include <itkBinaryMask3DMeshSource.h>
#include <itkImage.h>
#include <itkMesh.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "evaluate/distance_samples.h"
#include "evaluate/fidelity.h"
#include "evaluate/quality.h"
#include "evaluate/triangle_grid.h"
#include "fields/marching_cubes.h"
#include "phantoms.h"

using namespace cvt;

namespace {

// The surface of one ITK run over the whole mask padded by a voxel, vertices snapped to half
// voxels and oriented outward: what marching_cubes must give by its table of ITK's cases.
TriangleSurface one_itk_run(const Mask& mask) {
  using Image = itk::Image<unsigned char, 3>;
  using Mesh = itk::Mesh<double, 3>;
  const Grid& g = mask.grid;
  auto image = Image::New();
  Image::RegionType region;
  for (unsigned a = 0; a < 3; ++a) region.SetSize(a, itk::SizeValueType(g.dims[a] + 2));
  image->SetRegions(region);
  image->Allocate();
  image->FillBuffer(0);
  const std::size_t nx = std::size_t(g.dims[0]) + 2, ny = std::size_t(g.dims[1]) + 2;
  for (int k = 0; k < g.dims[2]; ++k)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i)
        image->GetBufferPointer()[(std::size_t(k + 1) * ny + std::size_t(j + 1)) * nx +
                                  std::size_t(i + 1)] = mask.at(i, j, k) != 0;
  auto filter = itk::BinaryMask3DMeshSource<Image, Mesh>::New();
  filter->SetInput(image);
  filter->SetObjectValue(1);
  filter->Update();
  TriangleSurface s;
  const Mesh* mesh = filter->GetOutput();
  s.vertices.resize(mesh->GetNumberOfPoints());
  for (auto it = mesh->GetPoints()->Begin(); it != mesh->GetPoints()->End(); ++it) {
    Vec3 index;
    for (int a = 0; a < 3; ++a) index[a] = std::round(2 * it.Value()[unsigned(a)]) / 2 - 1;
    s.vertices[it.Index()] = g.index_to_world(index);
  }
  for (auto it = mesh->GetCells()->Begin(); it != mesh->GetCells()->End(); ++it) {
    const auto* id = it.Value()->PointIdsBegin();
    s.triangles.push_back({std::int32_t(id[0]), std::int32_t(id[1]), std::int32_t(id[2])});
  }
  double volume = 0;
  for (const Triangle& t : s.triangles)
    volume += dot(s.vertices[t[0]], cross(s.vertices[t[1]], s.vertices[t[2]]));
  if (volume < 0)
    for (Triangle& t : s.triangles) std::swap(t[1], t[2]);
  return s;
}

// The triangles as coordinate triples, each rotated to start at its smallest vertex, sorted.
std::vector<std::array<double, 9>> triangle_set(const TriangleSurface& s) {
  std::vector<std::array<double, 9>> out;
  for (const Triangle& t : s.triangles) {
    auto key = [&](int i) {
      const Vec3& v = s.vertices[t[i]];
      return std::make_tuple(v.x, v.y, v.z);
    };
    int first = 0;
    for (int i = 1; i < 3; ++i)
      if (key(i) < key(first)) first = i;
    std::array<double, 9> c;
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a) c[3 * i + a] = s.vertices[t[(first + i) % 3]][a];
    out.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

Mask phantom_mask(const Phantom& p, const Vec3& spacing) {
  const Image image = rasterize(p, grid_around(p, spacing, rotation_matrix({1, 2, 0.5}, 0.6)));
  Mask mask(image.grid());
  for (std::size_t i = 0; i < mask.size(); ++i) mask.data[i] = image.voxels.data[i] > 0.5f;
  return mask;
}

void expect_same_surface_as_one_run(const Mask& mask, const std::string& name) {
  const TriangleSurface table = marching_cubes(mask), one = one_itk_run(mask);
  EXPECT_EQ(table.vertices.size(), one.vertices.size()) << name;
  EXPECT_EQ(triangle_set(table), triangle_set(one)) << name;
  const SurfaceTopology a = surface_topology(table.triangles, table.vertices.size());
  const SurfaceTopology b = surface_topology(one.triangles, one.vertices.size());
  EXPECT_TRUE(a.closed_manifold) << name;
  EXPECT_EQ(a.euler_characteristic, b.euler_characteristic) << name;
  EXPECT_EQ(a.components, b.components) << name;
}

// A random soup: triangles of very different sizes, some degenerate (collinear, or a point).
TriangleSurface random_soup(std::mt19937& rng, std::size_t n) {
  std::uniform_real_distribution<double> where(-10, 10), size(-1, 1);
  std::uniform_int_distribution<int> kind(0, 9);
  TriangleSurface s;
  for (std::size_t t = 0; t < n; ++t) {
    const Vec3 a{where(rng), where(rng), where(rng)};
    const double scale = kind(rng) < 2 ? 6.0 : 0.5;
    Vec3 b = a + Vec3{size(rng), size(rng), size(rng)} * scale;
    Vec3 c = a + Vec3{size(rng), size(rng), size(rng)} * scale;
    if (kind(rng) == 0) c = a + (b - a) * 0.3;  // collinear
    if (kind(rng) == 1) b = a, c = a;           // a point
    const auto i = std::int32_t(s.vertices.size());
    s.vertices.insert(s.vertices.end(), {a, b, c});
    s.triangles.push_back({i, i + 1, i + 2});
  }
  return s;
}

// Reference point–triangle distance by another route: the plane when the projection falls
// inside (barycentric coordinates), else the nearest of the three edges.
double reference_squared_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  auto segment = [&](const Vec3& s, const Vec3& t) {
    const Vec3 st = t - s;
    const double l = squared_norm(st);
    const double u = l > 0 ? std::clamp(dot(p - s, st) / l, 0.0, 1.0) : 0.0;
    return squared_norm(p - (s + st * u));
  };
  double best = std::min({segment(a, b), segment(b, c), segment(c, a)});
  const Vec3 n = cross(b - a, c - a);
  const double nn = squared_norm(n);
  if (nn > 1e-20) {
    const Vec3 q = p - n * (dot(p - a, n) / nn);
    const double u = dot(cross(c - b, q - b), n), v = dot(cross(a - c, q - c), n),
                 w = dot(cross(b - a, q - a), n);
    if (u >= 0 && v >= 0 && w >= 0) best = std::min(best, squared_norm(p - q));
  }
  return best;
}

}  // namespace

TEST(MarchingCubes, SameSurfaceAsOneItkRunOnPhantoms) {
  // Fine z spacing so that every object spans many cube layers (built in parallel).
  const Vec3 spacing{0.7, 0.8, 0.35};
  for (const Phantom& p :
       {sphere_phantom({3, -2, 5}, 6.0), torus_phantom({1, 2, 3}, 8.0, 3.0),
        hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0), two_spheres_phantom({0, 0, 0}, 4.0, 0.0)}) {
    const Mask mask = phantom_mask(p, spacing);
    ASSERT_GT(mask.grid.dims[2], 40) << p.name;
    expect_same_surface_as_one_run(mask, p.name);
  }
}

// Noise puts every cube configuration, ambiguous ones included, in the mask and on the planes
// the cube layers share.
TEST(MarchingCubes, SameSurfaceAsOneItkRunOnNoise) {
  Grid g;
  g.dims = {19, 14, 53};
  g.spacing = {0.7, 0.8, 1.1};
  g.origin = {4, -1, 2};
  g.direction = rotation_matrix({0.3, 1, -0.2}, 0.9);
  std::mt19937 rng(5);
  for (double density : {0.2, 0.5, 0.8}) {
    Mask mask(g, 0);
    std::bernoulli_distribution in(density);
    for (unsigned char& v : mask.data) v = in(rng);
    expect_same_surface_as_one_run(mask, "noise " + std::to_string(density));
  }
  // An object touching every border, and a single slice.
  expect_same_surface_as_one_run(Mask(g, 1), "full");
  Grid flat = g;
  flat.dims[2] = 1;
  expect_same_surface_as_one_run(Mask(flat, 1), "one slice");
  EXPECT_TRUE(marching_cubes(Mask(g, 0)).triangles.empty());
}

// The Euler characteristic counted from the cube cases equals the surface's own (V − E + F), on
// the phantoms (ball 2, torus 0, shell 4, two balls touching) and on noise, where every case,
// ambiguous ones included, and one-voxel tunnels and cavities abound.
TEST(MarchingCubes, EulerCharacteristicFromTheCasesEqualsTheSurfaces) {
  const auto surface_euler = [](const Mask& mask) {
    const TriangleSurface s = marching_cubes(mask);
    return surface_topology(s.triangles, s.vertices.size()).euler_characteristic;
  };
  const Vec3 spacing{0.7, 0.8, 0.9};
  const std::pair<Phantom, long long> known[] = {{sphere_phantom({3, -2, 5}, 6.0), 2},
                                                 {torus_phantom({1, 2, 3}, 8.0, 3.0), 0},
                                                 {hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0), 4}};
  for (const auto& [p, euler] : known) {
    const Mask mask = phantom_mask(p, spacing);
    EXPECT_EQ(marching_cubes_euler(mask), euler) << p.name;
    EXPECT_EQ(surface_euler(mask), euler) << p.name;
  }
  const Mask touching = phantom_mask(two_spheres_phantom({0, 0, 0}, 4.0, 0.0), spacing);
  EXPECT_EQ(marching_cubes_euler(touching), surface_euler(touching));
  Grid g;
  g.dims = {23, 17, 29};
  g.spacing = spacing;
  std::mt19937 rng(11);
  for (double density : {0.1, 0.3, 0.5, 0.7, 0.9}) {
    Mask mask(g, 0);
    std::bernoulli_distribution in(density);
    for (unsigned char& v : mask.data) v = in(rng);
    EXPECT_EQ(marching_cubes_euler(mask), surface_euler(mask)) << density;
  }
  EXPECT_EQ(marching_cubes_euler(Mask(g, 1)), 2);
  EXPECT_EQ(marching_cubes_euler(Mask(g, 0)), 0);
}

TEST(PointTriangleDistance, EqualsAReferenceOnRandomTriangles) {
  std::mt19937 rng(3);
  const TriangleSurface soup = random_soup(rng, 2000);
  std::uniform_real_distribution<double> where(-12, 12);
  for (const Triangle& t : soup.triangles) {
    const Vec3 &a = soup.vertices[t[0]], &b = soup.vertices[t[1]], &c = soup.vertices[t[2]];
    for (int q = 0; q < 5; ++q) {
      const Vec3 p{where(rng), where(rng), where(rng)};
      const double d = point_triangle_squared_distance(p, a, b, c);
      const double ref = reference_squared_distance(p, a, b, c);
      EXPECT_NEAR(d, ref, 1e-9 * (1 + ref));
    }
    // On the triangle: zero.
    EXPECT_NEAR(point_triangle_squared_distance((a + b + c) * (1.0 / 3), a, b, c), 0, 1e-24);
    EXPECT_EQ(point_triangle_squared_distance(b, a, b, c), 0);
  }
}

TEST(TriangleGrid, NearestEqualsBruteForce) {
  std::mt19937 rng(7);
  for (std::size_t n : {1, 7, 300, 3000}) {
    const TriangleSurface soup = random_soup(rng, n);
    for (double cell : {0.0, 0.3, 5.0}) {
      const TriangleGrid grid(soup, cell);
      std::uniform_real_distribution<double> where(-25, 25);
      std::uniform_int_distribution<std::int32_t> any(-1, std::int32_t(n) - 1);
      for (int q = 0; q < 300; ++q) {
        const Vec3 p = q % 3 == 0 ? soup.vertices[std::size_t(q) % soup.vertices.size()]
                                  : Vec3{where(rng), where(rng), where(rng)};
        double brute = std::numeric_limits<double>::infinity();
        for (const Triangle& t : soup.triangles)
          brute = std::min(
              brute, point_triangle_squared_distance(p, soup.vertices[t[0]], soup.vertices[t[1]],
                                                     soup.vertices[t[2]]));
        EXPECT_EQ(grid.squared_distance(p), brute) << n << " " << cell;
        // Any starting guess gives the same answer, and the nearest triangle is reported.
        std::int32_t nearest = any(rng);
        EXPECT_EQ(grid.squared_distance(p, &nearest), brute) << n << " " << cell;
        ASSERT_GE(nearest, 0);
        const Triangle& t = soup.triangles[std::size_t(nearest)];
        EXPECT_EQ(point_triangle_squared_distance(p, soup.vertices[t[0]], soup.vertices[t[1]],
                                                  soup.vertices[t[2]]),
                  brute);
      }
    }
  }
  const TriangleSurface none;
  EXPECT_TRUE(TriangleGrid(none).empty());
  EXPECT_EQ(TriangleGrid(none).squared_distance({1, 2, 3}),
            std::numeric_limits<double>::infinity());
}

// A marching-cubes surface: a million-triangle case in miniature, queried off the surface too.
TEST(TriangleGrid, NearestOnAMarchingCubesSurfaceEqualsBruteForce) {
  const TriangleSurface s =
      marching_cubes(phantom_mask(torus_phantom({1, 2, 3}, 8.0, 3.0), {0.7, 0.8, 1.1}));
  const TriangleGrid grid(s);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> where(-14, 14);
  for (int q = 0; q < 200; ++q) {
    const Vec3 p = Vec3{1, 2, 3} + Vec3{where(rng), where(rng), where(rng) / 2};
    double brute = std::numeric_limits<double>::infinity();
    for (const Triangle& t : s.triangles)
      brute = std::min(brute, point_triangle_squared_distance(p, s.vertices[t[0]], s.vertices[t[1]],
                                                              s.vertices[t[2]]));
    EXPECT_EQ(grid.squared_distance(p), brute);
  }
}

TEST(DistanceSamples, GroupsCoverTheSurfaceOnceWithinTheirReach) {
  std::mt19937 rng(9);
  const TriangleSurface soup = random_soup(rng, 500);
  double area = 0;
  for (const Triangle& t : soup.triangles)
    area += 0.5 * norm(cross(soup.vertices[t[1]] - soup.vertices[t[0]],
                             soup.vertices[t[2]] - soup.vertices[t[0]]));
  for (double h : {0.2, 0.7, 3.0}) {
    const DistanceSamples samples(soup, h);
    double total = 0, pieces_area = 0;
    for (std::size_t g = 0; g < samples.size(); ++g) {
      total += samples.area(g);
      bool at_a_centroid = false;
      for (const TrianglePiece& p : samples.pieces(g)) {
        pieces_area += 0.5 * norm(cross(p.b - p.a, p.c - p.a));
        for (const Vec3& v : {p.a, p.b, p.c}) {
          EXPECT_LE(distance(v, samples.at(g)), samples.reach(g) + 1e-12);
          EXPECT_LE(distance(v, p.a), h * (1 + 1e-12));  // edges ≤ h
        }
        at_a_centroid |= distance((p.a + p.b + p.c) * (1.0 / 3), samples.at(g)) < 1e-12;
      }
      EXPECT_TRUE(at_a_centroid);
    }
    EXPECT_NEAR(total, area, 1e-9 * area) << h;
    EXPECT_NEAR(pieces_area, area, 1e-9 * area) << h;
  }
}

// Fewer samples than triangles on a surface of small triangles: about one per h².
TEST(DistanceSamples, AboutOnePerCubeOnAMarchingCubesSurface) {
  const TriangleSurface s =
      marching_cubes(phantom_mask(sphere_phantom({0, 0, 0}, 10.0), {0.7, 0.8, 1.1}));
  const double h = 1.4;
  const DistanceSamples samples(s, h);
  double area = 0;
  for (std::size_t g = 0; g < samples.size(); ++g) area += samples.area(g);
  EXPECT_LT(samples.size(), s.triangles.size() / 2);
  EXPECT_GT(double(samples.size()), 0.5 * area / (h * h));
  EXPECT_LT(double(samples.size()), 3 * area / (h * h));
}

// compute_fidelity's object-surface topology (Euler characteristic V − F/2 of the closed
// marching-cubes surface, components) equals the full check's.
TEST(Fidelity, ObjectSurfaceTopologyEqualsTheFullCheck) {
  for (const Phantom& p :
       {hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0), torus_phantom({1, 2, 3}, 8.0, 3.0)}) {
    const Mask mask = phantom_mask(p, {0.7, 0.8, 1.1});
    const TriangleSurface s = marching_cubes(mask);
    const SurfaceTopology full = surface_topology(s.triangles, s.vertices.size());
    const FidelityReport rep = compute_fidelity(voxel_tet_mesh(mask), mask);
    EXPECT_EQ(rep.object_surface_euler, full.euler_characteristic) << p.name;
    EXPECT_EQ(rep.object_surface_components, full.components) << p.name;
    EXPECT_EQ(rep.object_surface_triangles, s.triangles.size()) << p.name;
  }
}

// The same figures, bit for bit, whatever the thread count.
TEST(Fidelity, SameFiguresOnAnyThreadCount) {
  const Mask mask = phantom_mask(torus_phantom({1, 2, 3}, 8.0, 3.0), {0.7, 0.8, 0.35});
  TetMesh mesh = voxel_tet_mesh(mask);
  for (Vec3& v : mesh.vertices) v = v + Vec3{0.05, -0.03, 0.02} + v * 0.01;
  auto figures = [&](int threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    std::size_t(threads));
    const FidelityReport r = compute_fidelity(mesh, mask);
    return std::vector<double>{r.volume_error_percent,     r.distance.hausdorff_mm,
                               r.distance.mean_mm,         r.distance.p95_mm,
                               r.distance.a_to_b_max_at.x, r.distance.b_to_a_max_at.y,
                               r.distance.a_to_b_mean_mm,  double(r.distance.samples_b)};
  };
  const std::vector<double> one = figures(1);
  EXPECT_EQ(figures(2), one);
  EXPECT_EQ(figures(4), one);
}
