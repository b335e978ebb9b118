// Geometric fidelity: volume error and sampled symmetric surface distances (exact
// point–triangle distances through a grid of triangle buckets).
#include "evaluate/fidelity.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <tuple>

#include "base/errors.h"
#include "evaluate/distance_samples.h"
#include "evaluate/quality.h"
#include "evaluate/triangle_grid.h"

namespace cvt {
namespace {

// Distances to the nearest triangle of a surface.
class NearestTriangle {
 public:
  explicit NearestTriangle(const TriangleSurface& target) : grid_(target) {}

  // Distances of points(i), i in [0, n), in parallel; +inf for an empty target.
  template <class PointAt>
  std::vector<double> distances(std::size_t n, const PointAt& point,
                                const Progress& progress) const {
    std::vector<double> d(n, std::numeric_limits<double>::infinity());
    if (grid_.empty()) return d;
    // A thrown Cancelled cancels the other chunks and reaches the caller (TBB rethrows it).
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const auto& r) {
      progress.check_cancelled();
      std::int32_t nearest = -1;  // the previous point's: samples in order are neighbours
      for (std::size_t i = r.begin(); i != r.end(); ++i)
        d[i] = std::sqrt(grid_.squared_distance(point(i), &nearest));
    });
    return d;
  }
  double distance(const Vec3& p) const { return std::sqrt(grid_.squared_distance(p)); }

 private:
  TriangleGrid grid_;
};

// A piece of a triangle and the distance at its centroid.
struct Piece {
  Vec3 a, b, c;
  double d;
};

Vec3 centroid(const Piece& p) {
  return (p.a + p.b + p.c) * (1.0 / 3);
}

// Farthest a point of the piece can be from its centroid.
double reach(const Piece& p) {
  const Vec3 m = centroid(p);
  return std::sqrt(
      std::max({squared_distance(m, p.a), squared_distance(m, p.b), squared_distance(m, p.c)}));
}

// The distance to a surface is 1-Lipschitz: no point of a piece is farther than d + reach. A
// piece that could hold a point more than `tolerance` farther than the largest value known is
// split in four (its corners sampled too: a distance linear over the piece peaks there), at most
// kMaxSplits times. Returns the largest distance found and where (depth first: deterministic for
// each piece).
constexpr int kMaxSplits = 4;  // pieces down to 1/16 of the sample spacing
constexpr std::size_t kRefinedGroups = 1024, kRefinedPieces = 256;
std::pair<double, Vec3> refine_maximum(const Piece& p, double floor, double tolerance,
                                       const NearestTriangle& target) {
  std::pair<double, Vec3> best{p.d, centroid(p)};
  std::vector<std::pair<Piece, int>> stack{{p, 0}};
  while (!stack.empty()) {
    const auto [q, depth] = stack.back();
    stack.pop_back();
    const double r = reach(q);
    if (depth == kMaxSplits || r <= tolerance || q.d + r <= std::max(floor, best.first) + tolerance)
      continue;
    for (const Vec3& corner : {q.a, q.b, q.c}) {
      const double d = target.distance(corner);
      if (d > best.first) best = {d, corner};
    }
    const Vec3 ab = (q.a + q.b) * 0.5, bc = (q.b + q.c) * 0.5, ca = (q.c + q.a) * 0.5;
    for (Piece child : {Piece{q.a, ab, ca, 0}, Piece{ab, q.b, bc, 0}, Piece{ca, bc, q.c, 0},
                        Piece{ab, bc, ca, 0}}) {
      const Vec3 m = centroid(child);
      child.d = target.distance(m);
      if (child.d > best.first) best = {child.d, m};
      stack.push_back({child, depth + 1});
    }
  }
  return best;
}

// One direction: the distance of every sample of `from` to `to`, summarised; the maximum is
// then refined where the Lipschitz bound allows a larger one.
struct OneSide {
  double max = 0, mean = 0, sum = 0, weight = 0;
  Vec3 max_at;
  std::size_t samples = 0;
};

OneSide one_side(const DistanceSamples& samples, const NearestTriangle& to, double tolerance,
                 std::vector<std::pair<double, double>>& all, const Progress& progress) {
  OneSide out;
  const std::size_t n = samples.size();
  const std::vector<double> d = to.distances(
      n, [&](std::size_t i) { return samples.at(i); }, progress);
  progress.check_cancelled();
  out.samples = n;
  all.reserve(all.size() + n);
  for (std::size_t i = 0; i < n; ++i) {
    const double w = samples.area(i);
    if (d[i] > out.max) out.max = d[i], out.max_at = samples.at(i);
    out.sum += w * d[i], out.weight += w;
    all.emplace_back(d[i], w);
  }
  out.mean = out.weight > 0 ? out.sum / out.weight : 0;

  // The maximum is refined where the Lipschitz bound allows a larger one, in two rounds that
  // each take the candidates with the largest bound (above the maximum known before the round,
  // so the result does not depend on scheduling): the groups, measured piece by piece, then
  // their pieces, split by refine_maximum.
  auto largest_bounds = [&](std::vector<std::pair<double, std::size_t>>& bound, std::size_t most) {
    bound.erase(std::remove_if(bound.begin(), bound.end(),
                               [&](const auto& b) { return -b.first <= out.max + tolerance; }),
                bound.end());
    most = std::min(most, bound.size());
    std::partial_sort(bound.begin(), bound.begin() + std::ptrdiff_t(most), bound.end());
    bound.resize(most);
  };
  std::vector<std::pair<double, std::size_t>> bound;  // (−bound, group): largest first
  for (std::size_t g = 0; g < n; ++g) bound.emplace_back(-(d[g] + samples.reach(g)), g);
  largest_bounds(bound, kRefinedGroups);
  std::vector<Piece> pieces;
  for (const auto& [b, g] : bound)
    for (const TrianglePiece& t : samples.pieces(g)) pieces.push_back({t.a, t.b, t.c, 0});
  progress.check_cancelled();
  tbb::parallel_for(std::size_t(0), pieces.size(),
                    [&](std::size_t i) { pieces[i].d = to.distance(centroid(pieces[i])); });
  for (const Piece& p : pieces)  // in bound order: the first of equal maxima wins
    if (p.d > out.max) out.max = p.d, out.max_at = centroid(p);

  bound.clear();
  for (std::size_t i = 0; i < pieces.size(); ++i)
    bound.emplace_back(-(pieces[i].d + reach(pieces[i])), i);
  largest_bounds(bound, kRefinedPieces);
  const double floor = out.max;
  std::vector<std::pair<double, Vec3>> found(bound.size());
  tbb::parallel_for(std::size_t(0), bound.size(), [&](std::size_t i) {
    if (i % 16 == 0) progress.check_cancelled();
    found[i] = refine_maximum(pieces[bound[i].second], floor, tolerance, to);
  });
  for (const auto& [dist, at] : found)
    if (dist > out.max) out.max = dist, out.max_at = at;
  return out;
}

double diagonal(const TriangleSurface& s) {
  if (s.vertices.empty()) return 0;
  Vec3 lo = s.vertices[0], hi = s.vertices[0];
  for (const Vec3& p : s.vertices)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  return norm(hi - lo);
}

// Euler characteristic and components of a closed surface (every edge in two triangles, so
// E = 3F/2): V − F/2, and the components by union–find over the triangles' vertices.
std::pair<long long, std::size_t> closed_surface_topology(const TriangleSurface& s) {
  std::vector<std::int32_t> parent(s.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<char> used(s.vertices.size(), 0);
  for (const Triangle& t : s.triangles) {
    for (std::int32_t v : t) used[std::size_t(v)] = 1;
    for (int e = 1; e < 3; ++e) {
      const std::int32_t a = find(t[0]), b = find(t[e]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  long long vertices = 0;
  std::size_t components = 0;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v]) ++vertices, components += find(std::int32_t(v)) == std::int32_t(v);
  return {vertices - (long long)(s.triangles.size() / 2), components};
}

}  // namespace

SurfaceDistance surface_distance(const TriangleSurface& a, const TriangleSurface& b,
                                 const SurfaceDistanceOptions& options, const Progress& progress) {
  SurfaceDistance out;
  double h = options.sample_spacing_mm > 0 ? options.sample_spacing_mm
                                           : std::max(diagonal(a), diagonal(b)) / 200;
  if (!(h > 0)) h = 1;  // empty or single-point surfaces
  // Coarsen until both surfaces stay below max_samples (samples scale as 1/h²), while the grids
  // are built (each build is serial, hence the three at once).
  std::optional<DistanceSamples> sa, sb;
  std::optional<NearestTriangle> to_a, to_b;
  auto sample = [&] {
    for (int guard = 0; guard < 60; ++guard) {
      progress.check_cancelled();
      tbb::parallel_invoke([&] { sa.emplace(a, h); }, [&] { sb.emplace(b, h); });
      const std::size_t n = std::max(sa->size(), sb->size());
      if (n <= options.max_samples) break;
      h *= std::max(1.05, std::sqrt(double(n) / double(options.max_samples)));
    }
  };
  tbb::parallel_invoke(
      sample, [&] { to_a.emplace(a); }, [&] { to_b.emplace(b); });
  out.sample_spacing_mm = h;
  const double tolerance = options.max_error_mm > 0 ? options.max_error_mm : 0.02 * h;
  // (distance, weight) over both directions, for the mean and the percentile.
  std::vector<std::pair<double, double>> all;
  progress.check_cancelled();
  const OneSide ab = one_side(*sa, *to_b, tolerance, all, progress);
  const OneSide ba = one_side(*sb, *to_a, tolerance, all, progress);
  out.samples_a = ab.samples, out.samples_b = ba.samples;
  out.a_to_b_max_mm = ab.max, out.a_to_b_max_at = ab.max_at, out.a_to_b_mean_mm = ab.mean;
  out.b_to_a_max_mm = ba.max, out.b_to_a_max_at = ba.max_at, out.b_to_a_mean_mm = ba.mean;
  out.hausdorff_mm = std::max(out.a_to_b_max_mm, out.b_to_a_max_mm);
  const double weight = ab.weight + ba.weight;
  out.mean_mm = weight > 0 ? (ab.sum + ba.sum) / weight : 0;
  tbb::parallel_sort(all.begin(), all.end());
  double cumulative = 0;
  for (const auto& [d, w] : all) {
    cumulative += w;
    out.p95_mm = d;
    if (cumulative >= 0.95 * weight) break;
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
  const Vec3& s = object.grid.spacing;
  progress.check_cancelled();
  // The marching cubes beside the mesh's boundary and volumes.
  TriangleSurface reference, boundary;
  tbb::parallel_invoke([&] { reference = marching_cubes(object); },
                       [&] {
                         boundary = boundary_surface(mesh);
                         for (const Tet& t : mesh.tets)
                           rep.mesh_volume_mm3 += signed_volume(mesh, t);
                         const auto voxels = std::count_if(object.data.begin(), object.data.end(),
                                                           [](unsigned char v) { return v != 0; });
                         rep.object_volume_mm3 = double(voxels) * s.x * s.y * s.z;
                       });
  if (rep.object_volume_mm3 > 0)
    rep.volume_error_percent =
        100.0 * (rep.mesh_volume_mm3 - rep.object_volume_mm3) / rep.object_volume_mm3;
  progress.check_cancelled();
  rep.object_surface_triangles = reference.triangles.size();
  std::tie(rep.object_surface_euler, rep.object_surface_components) =
      closed_surface_topology(reference);
  SurfaceDistanceOptions sd;
  sd.sample_spacing_mm = options.sample_spacing_voxels * std::min({s.x, s.y, s.z});
  sd.max_samples = options.max_samples;
  progress.check_cancelled();
  rep.distance = surface_distance(boundary, reference, sd, progress);
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
