#include "evaluate/distance_samples.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "base/memory.h"

namespace cvt {
namespace {

Vec3 centroid(const TrianglePiece& p) {
  return (p.a + p.b + p.c) * (1.0 / 3);
}
double piece_area(const TrianglePiece& p) {
  return 0.5 * norm(cross(p.b - p.a, p.c - p.a));
}

// Pieces per edge so that each piece's edges are ≤ h.
std::uint32_t subdivisions(const TriangleSurface& s, const Triangle& t, double h) {
  const Vec3 &a = s.vertices[t[0]], &b = s.vertices[t[1]], &c = s.vertices[t[2]];
  const double longest =
      std::sqrt(std::max({squared_distance(a, b), squared_distance(b, c), squared_distance(c, a)}));
  return std::max<std::uint32_t>(1, std::uint32_t(std::ceil(longest / h)));
}

// A number in [0, 1) from a key (splitmix64's finaliser).
double unit_hash(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return double((x ^ (x >> 31)) >> 11) * 0x1p-53;
}

}  // namespace

TrianglePiece DistanceSamples::piece(std::uint32_t triangle, std::uint32_t index) const {
  const Triangle& t = surface_->triangles[triangle];
  const double k = k_[triangle];
  const Vec3& a = surface_->vertices[t[0]];
  const Vec3 u = (surface_->vertices[t[1]] - a) * (1.0 / k),
             w = (surface_->vertices[t[2]] - a) * (1.0 / k);
  const std::uint32_t ij = index / 2, i = ij / k_[triangle], j = ij % k_[triangle];
  const Vec3 p = a + u * double(i) + w * double(j);
  if (index % 2 == 0) return {p, p + u, p + w};
  return {p + u, p + u + w, p + w};
}

std::vector<TrianglePiece> DistanceSamples::pieces(std::size_t g) const {
  std::vector<TrianglePiece> out;
  out.reserve(start_[g + 1] - start_[g]);
  for (std::uint32_t m = start_[g]; m < start_[g + 1]; ++m)
    out.push_back(piece(members_[m].first, members_[m].second));
  return out;
}

DistanceSamples::DistanceSamples(const TriangleSurface& surface, double h) : surface_(&surface) {
  const auto& tris = surface.triangles;
  const std::size_t n = tris.size();
  if (n == 0) return;
  k_.resize(n);
  tbb::parallel_for(std::size_t(0), n,
                    [&](std::size_t t) { k_[t] = subdivisions(surface, tris[t], h); });
  std::vector<std::size_t> first(n + 1, 0);  // pieces before triangle t
  for (std::size_t t = 0; t < n; ++t) first[t + 1] = first[t] + std::size_t(k_[t]) * k_[t];
  Vec3 lo = surface.vertices[tris[0][0]];
  for (const Triangle& t : tris)
    for (std::int32_t v : t)
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], surface.vertices[v][a]);

  // (cube, triangle, piece) for every piece, sorted: the groups are the runs of one cube.
  constexpr int kBits = 21;  // per axis of the cube key
  std::vector<std::tuple<std::uint64_t, std::uint32_t, std::uint32_t>> keyed;
  resize_large(keyed, first.back());  // large buffers are faulted in on all threads
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t t) {
    std::size_t at = first[t];
    const std::uint32_t k = k_[t];
    for (std::uint32_t i = 0; i < k; ++i)
      for (std::uint32_t j = 0; i + j < k; ++j)
        for (std::uint32_t upper = 0; upper < (i + j + 2 <= k ? 2u : 1u); ++upper) {
          const std::uint32_t index = (i * k + j) * 2 + upper;
          const Vec3 m = centroid(piece(std::uint32_t(t), index));
          std::uint64_t key = 0;
          for (int a = 2; a >= 0; --a)
            key = (key << kBits) | std::min<std::uint64_t>(std::uint64_t((m[a] - lo[a]) / h),
                                                           (std::uint64_t(1) << kBits) - 1);
          keyed[at++] = {key, std::uint32_t(t), index};
        }
  });
  // Sorted by cube, stably (pieces stay in (triangle, piece) order within a cube): a counting
  // sort by the cube's z, then each z layer sorted on its own, in parallel.
  std::vector<std::size_t> layer(1, 0);
  for (const auto& e : keyed) {
    const std::size_t z = std::size_t(std::get<0>(e) >> (2 * kBits));
    if (layer.size() < z + 2) layer.resize(z + 2, 0);
    ++layer[z + 1];
  }
  for (std::size_t z = 1; z < layer.size(); ++z) layer[z] += layer[z - 1];
  {
    std::vector<std::tuple<std::uint64_t, std::uint32_t, std::uint32_t>> by_layer;
    resize_large(by_layer, keyed.size());
    std::vector<std::size_t> fill(layer.begin(), layer.end() - 1);
    for (const auto& e : keyed) by_layer[fill[std::size_t(std::get<0>(e) >> (2 * kBits))]++] = e;
    keyed.swap(by_layer);
  }
  tbb::parallel_for(std::size_t(0), layer.size() - 1, [&](std::size_t z) {
    std::stable_sort(keyed.begin() + std::ptrdiff_t(layer[z]),
                     keyed.begin() + std::ptrdiff_t(layer[z + 1]),
                     [](const auto& a, const auto& b) { return std::get<0>(a) < std::get<0>(b); });
  });
  resize_large(members_, keyed.size());
  std::vector<std::uint64_t> cube;  // per group
  for (std::size_t m = 0; m < keyed.size(); ++m) {
    if (m == 0 || std::get<0>(keyed[m]) != std::get<0>(keyed[m - 1]))
      start_.push_back(std::uint32_t(m)), cube.push_back(std::get<0>(keyed[m]));
    members_[m] = {std::get<1>(keyed[m]), std::get<2>(keyed[m])};
  }
  start_.push_back(std::uint32_t(keyed.size()));
  keyed = {};

  const std::size_t groups = start_.size() - 1;
  at_.resize(groups);
  area_.resize(groups);
  reach_.resize(groups);
  tbb::parallel_for(std::size_t(0), groups, [&](std::size_t g) {
    const std::vector<TrianglePiece> ps = pieces(g);
    std::vector<double> areas(ps.size());
    double total = 0;
    for (std::size_t i = 0; i < ps.size(); ++i) total += areas[i] = piece_area(ps[i]);
    // One piece, drawn with probability ∝ its area by a hash of the cube: an unbiased sample of
    // the group's mean distance (a fixed choice, such as the piece nearest the group's centre,
    // aliases with the lattice of a marching-cubes surface).
    const double pick = unit_hash(cube[g]) * total;
    std::size_t chosen = 0;
    for (double below = areas[0]; below <= pick && chosen + 1 < ps.size();)
      below += areas[++chosen];
    at_[g] = centroid(ps[chosen]);
    double reach2 = 0;
    for (const TrianglePiece& p : ps)
      for (const Vec3& v : {p.a, p.b, p.c}) reach2 = std::max(reach2, squared_distance(v, at_[g]));
    area_[g] = total;
    reach_[g] = std::sqrt(reach2);
  });
}

}  // namespace cvt
