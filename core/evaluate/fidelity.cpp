// Geometric fidelity: volume error and sampled symmetric surface distances (CGAL AABB tree for
// exact point–triangle distances).
#include "evaluate/fidelity.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "base/errors.h"
#include "evaluate/quality.h"

namespace cvt {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Triangle3 = Kernel::Triangle_3;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, std::vector<Triangle3>::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Kernel::Point_3 to_cgal(const Vec3& p) {
  return {p.x, p.y, p.z};
}

struct Sample {
  Vec3 position;
  double weight;  // area it stands for (mm²); 0 for vertices
};

// Pieces per edge so that each piece's edges are ≤ h.
std::size_t subdivisions(const TriangleSurface& s, const Triangle& t, double h) {
  const Vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
  const double longest =
      std::sqrt(std::max({squared_distance(a, b), squared_distance(b, c), squared_distance(c, a)}));
  return std::max<std::size_t>(1, std::size_t(std::ceil(longest / h)));
}

// Used vertices, then per triangle the centroids of its k² sub-triangles.
std::vector<Sample> distance_samples(const TriangleSurface& s, double h, const Progress& progress) {
  std::vector<char> used(s.vertices.size(), 0);
  for (const Triangle& t : s.triangles)
    for (std::int32_t v : t) used[std::size_t(v)] = 1;
  std::vector<std::size_t> first(s.triangles.size() + 1, 0);
  for (std::size_t t = 0; t < s.triangles.size(); ++t) {
    const std::size_t k = subdivisions(s, s.triangles[t], h);
    first[t + 1] = first[t] + k * k;
  }
  std::vector<Sample> samples;
  for (std::size_t v = 0; v < s.vertices.size(); ++v)
    if (used[v]) samples.push_back({s.vertices[v], 0});
  const std::size_t offset = samples.size();
  samples.resize(offset + first.back());
  tbb::parallel_for(std::size_t(0), s.triangles.size(), [&](std::size_t t) {
    if (t % 1024 == 0) progress.check_cancelled();
    const Triangle& tri = s.triangles[t];
    const Vec3 &a = s.vertices[tri[0]], u = s.vertices[tri[1]] - a, w = s.vertices[tri[2]] - a;
    const std::size_t k = subdivisions(s, tri, h);
    const double weight = 0.5 * norm(cross(u, w)) / double(k * k), kd = double(k);
    std::size_t out = offset + first[t];
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = 0; i + j < k; ++j) {
        samples[out++] = {a + u * ((i + 1.0 / 3) / kd) + w * ((j + 1.0 / 3) / kd), weight};
        if (i + j + 2 <= k)
          samples[out++] = {a + u * ((i + 2.0 / 3) / kd) + w * ((j + 2.0 / 3) / kd), weight};
      }
  });
  return samples;
}

// Number of area samples (vertices aside) at spacing h.
std::size_t area_sample_count(const TriangleSurface& s, double h) {
  std::size_t n = 0;
  for (const Triangle& t : s.triangles) {
    const std::size_t k = subdivisions(s, t, h);
    n += k * k;
  }
  return n;
}

// Distance of each sample to the nearest triangle of `target`.
std::vector<double> distances(const std::vector<Sample>& samples, const TriangleSurface& target,
                              const Progress& progress) {
  std::vector<Triangle3> triangles;
  triangles.reserve(target.triangles.size());
  for (const Triangle& t : target.triangles)
    triangles.emplace_back(to_cgal(target.vertices[t[0]]), to_cgal(target.vertices[t[1]]),
                           to_cgal(target.vertices[t[2]]));
  std::vector<double> d(samples.size(), 0);
  if (triangles.empty()) {
    std::fill(d.begin(), d.end(), std::numeric_limits<double>::infinity());
    return d;
  }
  Tree tree(triangles.begin(), triangles.end());
  tree.build();
  tree.accelerate_distance_queries();  // built now, not lazily inside the parallel loop
  progress.check_cancelled();
  // A thrown Cancelled cancels the other chunks and reaches the caller (TBB rethrows it).
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, samples.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      if ((i - r.begin()) % 1024 == 0) progress.check_cancelled();
      d[i] = std::sqrt(tree.squared_distance(to_cgal(samples[i].position)));
    }
  });
  return d;
}

double diagonal(const TriangleSurface& s) {
  if (s.vertices.empty()) return 0;
  Vec3 lo = s.vertices[0], hi = s.vertices[0];
  for (const Vec3& p : s.vertices)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  return norm(hi - lo);
}

}  // namespace

SurfaceDistance surface_distance(const TriangleSurface& a, const TriangleSurface& b,
                                 const SurfaceDistanceOptions& options, const Progress& progress) {
  SurfaceDistance out;
  double h = options.sample_spacing_mm > 0 ? options.sample_spacing_mm
                                           : std::max(diagonal(a), diagonal(b)) / 200;
  if (!(h > 0)) h = 1;  // empty or single-point surfaces
  // Coarsen until both surfaces stay below max_samples (samples scale as 1/h²).
  for (int guard = 0; guard < 60; ++guard) {
    const std::size_t n = std::max(area_sample_count(a, h), area_sample_count(b, h));
    if (n <= options.max_samples || n == std::max(a.triangles.size(), b.triangles.size())) break;
    h *= std::max(1.05, std::sqrt(double(n) / double(options.max_samples)));
  }
  out.sample_spacing_mm = h;
  // (distance, weight) over both directions, for the mean and the percentile. One direction
  // at a time, so its samples and distances are freed before the other's are made.
  std::vector<std::pair<double, double>> all;
  auto one_side = [&](const TriangleSurface& from, const TriangleSurface& to,
                      std::size_t& count, double& max, Vec3& max_at, double& mean) {
    const std::vector<Sample> s = distance_samples(from, h, progress);
    const std::vector<double> d = distances(s, to, progress);
    progress.check_cancelled();
    count = s.size();
    all.reserve(all.size() + s.size());
    double sum = 0, weight = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (d[i] > max) max = d[i], max_at = s[i].position;
      sum += s[i].weight * d[i], weight += s[i].weight;
      if (s[i].weight > 0) all.emplace_back(d[i], s[i].weight);
    }
    mean = weight > 0 ? sum / weight : 0;
    return std::pair{sum, weight};
  };
  const auto [sum_a, w_a] = one_side(a, b, out.samples_a, out.a_to_b_max_mm, out.a_to_b_max_at,
                                     out.a_to_b_mean_mm);
  const auto [sum_b, w_b] = one_side(b, a, out.samples_b, out.b_to_a_max_mm, out.b_to_a_max_at,
                                     out.b_to_a_mean_mm);
  out.hausdorff_mm = std::max(out.a_to_b_max_mm, out.b_to_a_max_mm);
  out.mean_mm = w_a + w_b > 0 ? (sum_a + sum_b) / (w_a + w_b) : 0;
  tbb::parallel_sort(all.begin(), all.end());
  double cumulative = 0;
  for (const auto& [d, w] : all) {
    cumulative += w;
    out.p95_mm = d;
    if (cumulative >= 0.95 * (w_a + w_b)) break;
  }
  return out;
}

TriangleSurface boundary_surface(const TetMesh& mesh) {
  // classify_faces gives boundary_triangles' result, in parallel (several times faster on
  // meshes of millions of tets).
  return {mesh.vertices, classify_faces(mesh).boundary};
}

SurfaceDistance surface_distance(const TetMesh& a, const TetMesh& b,
                                 const SurfaceDistanceOptions& options) {
  return surface_distance(boundary_surface(a), boundary_surface(b), options);
}

FidelityReport compute_fidelity(const TetMesh& mesh, const Mask& object,
                                const FidelityOptions& options, const Progress& progress) {
  FidelityReport rep;
  for (const Tet& t : mesh.tets) rep.mesh_volume_mm3 += signed_volume(mesh, t);
  const Vec3& s = object.grid.spacing;
  const auto voxels =
      std::count_if(object.data.begin(), object.data.end(), [](unsigned char v) { return v != 0; });
  rep.object_volume_mm3 = double(voxels) * s.x * s.y * s.z;
  if (rep.object_volume_mm3 > 0)
    rep.volume_error_percent =
        100.0 * (rep.mesh_volume_mm3 - rep.object_volume_mm3) / rep.object_volume_mm3;

  progress.check_cancelled();
  const TriangleSurface reference = marching_cubes(object);
  progress.check_cancelled();
  rep.object_surface_triangles = reference.triangles.size();
  const SurfaceTopology topology = surface_topology(reference.triangles, reference.vertices.size());
  rep.object_surface_euler = topology.euler_characteristic;
  rep.object_surface_components = topology.components;
  SurfaceDistanceOptions sd;
  sd.sample_spacing_mm = options.sample_spacing_voxels * std::min({s.x, s.y, s.z});
  sd.max_samples = options.max_samples;
  progress.check_cancelled();
  rep.distance = surface_distance(boundary_surface(mesh), reference, sd, progress);
  return rep;
}

Mask fidelity_object(const Image& image, const ObjectSelection& selection,
                     const CleanupOptions& cleanup) {
  Mask object = select_object(image, selection);
  clean_object(object, cleanup);
  if (std::find(object.data.begin(), object.data.end(), 1) == object.data.end())
    throw InputError(image.source + ": nothing is left of " + describe(selection) +
                     " after clean-up");
  return object;
}

nlohmann::json to_json(const FidelityReport& r) {
  const SurfaceDistance& d = r.distance;
  return {{"mesh_volume_mm3", r.mesh_volume_mm3},
          {"object_volume_mm3", r.object_volume_mm3},
          {"volume_error_percent", r.volume_error_percent},
          {"hausdorff_mm", d.hausdorff_mm},
          {"mean_mm", d.mean_mm},
          {"p95_mm", d.p95_mm},
          {"mesh_to_object",
           {{"max_mm", d.a_to_b_max_mm},
            {"max_at_mm", {d.a_to_b_max_at.x, d.a_to_b_max_at.y, d.a_to_b_max_at.z}},
            {"mean_mm", d.a_to_b_mean_mm}}},
          {"object_to_mesh",
           {{"max_mm", d.b_to_a_max_mm},
            {"max_at_mm", {d.b_to_a_max_at.x, d.b_to_a_max_at.y, d.b_to_a_max_at.z}},
            {"mean_mm", d.b_to_a_mean_mm}}},
          {"sample_spacing_mm", d.sample_spacing_mm},
          {"samples", {{"mesh", d.samples_a}, {"object", d.samples_b}}},
          {"object_surface_triangles", r.object_surface_triangles},
          {"object_surface_euler", r.object_surface_euler},
          {"object_surface_components", r.object_surface_components}};
}

}  // namespace cvt
