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

// Pieces per edge so that each piece's edges are ≤ h.
std::size_t subdivisions(const TriangleSurface& s, const Triangle& t, double h) {
  const Vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
  const double longest =
      std::sqrt(std::max({squared_distance(a, b), squared_distance(b, c), squared_distance(c, a)}));
  return std::max<std::size_t>(1, std::size_t(std::ceil(longest / h)));
}

// Distances to the nearest triangle of a surface (CGAL's AABB tree).
class NearestTriangle {
  static constexpr std::size_t kHintStride = 8;

 public:
  explicit NearestTriangle(const TriangleSurface& target) {
    triangles_.reserve(target.triangles.size());
    for (const Triangle& t : target.triangles)
      triangles_.emplace_back(to_cgal(target.vertices[t[0]]), to_cgal(target.vertices[t[1]]),
                              to_cgal(target.vertices[t[2]]));
    if (triangles_.empty()) return;
    tree_.insert(triangles_.begin(), triangles_.end());
    tree_.build();
    // The search tree of hints, built now (not lazily inside the parallel loops), from a vertex
    // of every kHintStride-th triangle: on a marching-cubes surface of tiny triangles, as good
    // a start for a query as one per triangle, at a fraction of the build.
    std::vector<Tree::Point_and_primitive_id> hints;
    for (std::size_t t = 0; t < triangles_.size(); t += kHintStride)
      hints.emplace_back(triangles_[t].vertex(0), triangles_.cbegin() + std::ptrdiff_t(t));
    tree_.accelerate_distance_queries(hints.begin(), hints.end());
  }
  bool empty() const { return triangles_.empty(); }

  // Distances of points(i), i in [0, n), in parallel; +inf for an empty target.
  template <class PointAt>
  std::vector<double> distances(std::size_t n, const PointAt& point, const Progress& progress) const {
    std::vector<double> d(n, std::numeric_limits<double>::infinity());
    if (empty()) return d;
    // A thrown Cancelled cancels the other chunks and reaches the caller (TBB rethrows it).
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const auto& r) {
      progress.check_cancelled();
      for (std::size_t i = r.begin(); i != r.end(); ++i)
        d[i] = std::sqrt(tree_.squared_distance(to_cgal(point(i))));
    });
    return d;
  }
  double distance(const Vec3& p) const {
    if (empty()) return std::numeric_limits<double>::infinity();
    return std::sqrt(tree_.squared_distance(to_cgal(p)));
  }

 private:
  std::vector<Triangle3> triangles_;
  Tree tree_;
};

// A piece of a triangle and the distance at its centroid.
struct Piece {
  Vec3 a, b, c;
  double d;
};

Vec3 centroid(const Piece& p) { return (p.a + p.b + p.c) * (1.0 / 3); }

// Farthest a point of the piece can be from its centroid.
double reach(const Piece& p) {
  const Vec3 m = centroid(p);
  return std::sqrt(std::max({squared_distance(m, p.a), squared_distance(m, p.b),
                             squared_distance(m, p.c)}));
}

// The distance to a surface is 1-Lipschitz: no point of a piece is farther than d + reach. A
// piece that could hold a point more than `tolerance` farther than the largest value known is
// split in four (its corners sampled too: a distance linear over the piece peaks there), at most
// kMaxSplits times. Returns the largest distance found and where (depth first: deterministic for
// each piece).
constexpr int kMaxSplits = 4;  // pieces down to 1/16 of the sample spacing
std::pair<double, Vec3> refine_maximum(const Piece& p, double floor, double tolerance,
                                       const NearestTriangle& target) {
  std::pair<double, Vec3> best{p.d, centroid(p)};
  std::vector<std::pair<Piece, int>> stack{{p, 0}};
  while (!stack.empty()) {
    const auto [q, depth] = stack.back();
    stack.pop_back();
    const double r = reach(q);
    if (depth == kMaxSplits || r <= tolerance ||
        q.d + r <= std::max(floor, best.first) + tolerance)
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

// One direction: the distance of every point of `from` to `to`, summarised. Each triangle is cut
// into k² pieces with edges ≤ h, sampled at their centroids and weighted by their area; the
// maximum is then refined where the Lipschitz bound allows a larger one.
struct OneSide {
  double max = 0, mean = 0, sum = 0, weight = 0;
  Vec3 max_at;
  std::size_t samples = 0;
};

OneSide one_side(const TriangleSurface& from, const NearestTriangle& to, double h,
                 double tolerance, std::vector<std::pair<double, double>>& all,
                 const Progress& progress) {
  OneSide out;
  std::vector<std::size_t> first(from.triangles.size() + 1, 0);  // pieces before triangle t
  for (std::size_t t = 0; t < from.triangles.size(); ++t) {
    const std::size_t k = subdivisions(from, from.triangles[t], h);
    first[t + 1] = first[t] + k * k;
  }
  std::vector<Piece> pieces(first.back());
  tbb::parallel_for(std::size_t(0), from.triangles.size(), [&](std::size_t t) {
    const Triangle& tri = from.triangles[t];
    const std::size_t k = subdivisions(from, tri, h);
    const Vec3 &a = from.vertices[tri[0]], u = (from.vertices[tri[1]] - a) * (1.0 / double(k)),
               w = (from.vertices[tri[2]] - a) * (1.0 / double(k));
    std::size_t out = first[t];
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = 0; i + j < k; ++j) {
        const Vec3 p = a + u * double(i) + w * double(j);
        pieces[out++] = {p, p + u, p + w, 0};
        if (i + j + 2 <= k) pieces[out++] = {p + u, p + u + w, p + w, 0};
      }
  });
  const std::vector<double> d =
      to.distances(pieces.size(), [&](std::size_t i) { return centroid(pieces[i]); }, progress);
  progress.check_cancelled();
  out.samples = pieces.size();
  all.reserve(all.size() + pieces.size());
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    Piece& p = pieces[i];
    p.d = d[i];
    const double w = 0.5 * norm(cross(p.b - p.a, p.c - p.a));
    if (p.d > out.max) out.max = p.d, out.max_at = centroid(p);
    out.sum += w * p.d, out.weight += w;
    all.emplace_back(p.d, w);
  }
  out.mean = out.weight > 0 ? out.sum / out.weight : 0;

  // The maximum is refined around the largest samples: the kRefined pieces with the largest
  // bound, as long as that bound exceeds the largest sample.
  constexpr std::size_t kRefined = 256;
  const double floor = out.max;
  std::vector<std::pair<double, std::size_t>> bound;  // (−bound, piece): largest first
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    const double b = pieces[i].d + reach(pieces[i]);
    if (b > floor + tolerance) bound.emplace_back(-b, i);
  }
  const std::size_t n = std::min(bound.size(), kRefined);
  std::partial_sort(bound.begin(), bound.begin() + std::ptrdiff_t(n), bound.end());
  std::vector<std::pair<double, Vec3>> found(n);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    if (i % 16 == 0) progress.check_cancelled();
    found[i] = refine_maximum(pieces[bound[i].second], floor, tolerance, to);
  });
  for (const auto& [dist, at] : found)  // in bound order: the first of equal maxima wins
    if (dist > out.max) out.max = dist, out.max_at = at;
  return out;
}

// Number of area samples at spacing h.
std::size_t area_sample_count(const TriangleSurface& s, double h) {
  std::size_t n = 0;
  for (const Triangle& t : s.triangles) {
    const std::size_t k = subdivisions(s, t, h);
    n += k * k;
  }
  return n;
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
  const double tolerance = options.max_error_mm > 0 ? options.max_error_mm : 0.02 * h;
  // (distance, weight) over both directions, for the mean and the percentile.
  std::vector<std::pair<double, double>> all;
  OneSide ab, ba;
  {
    const NearestTriangle to_b(b);
    ab = one_side(a, to_b, h, tolerance, all, progress);
  }
  {
    const NearestTriangle to_a(a);
    ba = one_side(b, to_a, h, tolerance, all, progress);
  }
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
