// Mesh validity: orientation and volume of each tet, vertex references, face adjacency and the
// topology of the boundary surface (closed 2-manifold, Euler characteristic, components).
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <functional>
#include <numeric>
#include <string>

#include "base/errors.h"
#include "evaluate/quality.h"

namespace cvt {
namespace {

// Parity of the permutation taking (t0, t1, t2) to sorted order.
std::uint8_t sort3(std::array<std::int32_t, 3>& t) {
  std::uint8_t swaps = 0;
  if (t[0] > t[1]) std::swap(t[0], t[1]), ++swaps;
  if (t[1] > t[2]) std::swap(t[1], t[2]), ++swaps;
  if (t[0] > t[1]) std::swap(t[0], t[1]), ++swaps;
  return swaps & 1;
}

struct UnionFind {
  std::vector<std::int32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  std::int32_t find(std::int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::int32_t a, std::int32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// True when the link edges around one vertex form a single cycle.
bool single_cycle(const std::vector<std::array<std::int32_t, 2>>& link) {
  if (link.size() < 3) return false;
  std::vector<std::int32_t> ends;
  for (const auto& e : link) ends.push_back(e[0]), ends.push_back(e[1]);
  std::sort(ends.begin(), ends.end());
  for (std::size_t i = 0; i < ends.size(); i += 2)
    if (ends[i] != ends[i + 1] || (i + 2 < ends.size() && ends[i + 2] == ends[i])) return false;
  // Every link vertex has degree 2: the edges form disjoint cycles; walk the first one.
  std::vector<char> used(link.size(), 0);
  used[0] = 1;
  std::int32_t at = link[0][1];
  std::size_t visited = 1;
  for (bool moved = true; moved;) {
    moved = false;
    for (std::size_t i = 0; i < link.size(); ++i) {
      if (used[i] || (link[i][0] != at && link[i][1] != at)) continue;
      used[i] = 1, ++visited, moved = true;
      at = link[i][0] == at ? link[i][1] : link[i][0];
      break;
    }
  }
  return visited == link.size();
}

}  // namespace

SurfaceTopology surface_topology(const std::vector<Triangle>& tris, std::size_t vertex_count) {
  SurfaceTopology v;
  v.triangles = tris.size();
  // Edges: (min, max, direction) per triangle side.
  std::vector<std::array<std::int32_t, 3>> edges;
  edges.reserve(3 * tris.size());
  for (const Triangle& t : tris)
    for (int s = 0; s < 3; ++s) {
      const std::int32_t a = t[s], b = t[(s + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), a < b ? 1 : 0});
    }
  tbb::parallel_sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1]) ++j;
    ++v.edges;
    if (j - i != 2)
      ++v.non_manifold_edges;
    else if (edges[i][2] == edges[i + 1][2])
      ++v.misoriented_edges;
    i = j;
  }
  // Vertex links: around vertex c of triangle (c, a, b) the link edge is (a, b).
  std::vector<std::array<std::int32_t, 3>> links;
  links.reserve(3 * tris.size());
  for (const Triangle& t : tris)
    for (int s = 0; s < 3; ++s) links.push_back({t[s], t[(s + 1) % 3], t[(s + 2) % 3]});
  tbb::parallel_sort(links.begin(), links.end());
  // Each vertex's link is checked on its own, so the vertices go in parallel (counts only).
  std::vector<std::size_t> first;  // where each vertex's run of links starts
  for (std::size_t i = 0; i < links.size(); ++i)
    if (i == 0 || links[i][0] != links[i - 1][0]) first.push_back(i);
  first.push_back(links.size());
  v.vertices = first.size() - 1;
  v.non_manifold_vertices = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, v.vertices), std::size_t(0),
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t bad) {
        std::vector<std::array<std::int32_t, 2>> link;
        for (std::size_t g = r.begin(); g != r.end(); ++g) {
          link.clear();
          for (std::size_t j = first[g]; j < first[g + 1]; ++j)
            link.push_back({links[j][1], links[j][2]});
          bad += !single_cycle(link);
        }
        return bad;
      },
      std::plus<>());
  v.euler_characteristic = (long long)v.vertices - (long long)v.edges + (long long)v.triangles;
  UnionFind uf(vertex_count);
  for (const Triangle& t : tris) uf.unite(t[0], t[1]), uf.unite(t[0], t[2]);
  std::vector<char> root(vertex_count, 0);
  for (const Triangle& t : tris) root[std::size_t(uf.find(t[0]))] = 1;
  v.components = std::size_t(std::count(root.begin(), root.end(), 1));
  v.closed_manifold = !tris.empty() && v.non_manifold_edges == 0 && v.misoriented_edges == 0 &&
                      v.non_manifold_vertices == 0;
  return v;
}

FaceUse classify_faces(const TetMesh& mesh) {
  const std::size_t n = mesh.tets.size(), nv = mesh.vertices.size();
  for (std::size_t t = 0; t < n; ++t)
    for (std::int32_t v : mesh.tets[t])
      if (v < 0 || std::size_t(v) >= nv)
        throw InputError("mesh: tet " + std::to_string(t) + " references vertex " +
                         std::to_string(v) + " but there are " + std::to_string(nv) + " vertices");
  // Core's face matching (parallel): a face shared by two tets links them; one used by three
  // or more links its tets in a cycle.
  const std::vector<std::int64_t> neighbour = face_neighbours(nv, mesh.tets);
  auto parity = [&](std::int64_t f) {
    std::array<std::int32_t, 3> v = outward_faces(mesh.tets[std::size_t(f / 4)])[f % 4];
    return sort3(v);
  };
  using Counts = std::array<std::size_t, 2>;  // shared by more than two, overlapping
  const Counts counts = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, neighbour.size(), 4096), Counts{0, 0},
      [&](const auto& r, Counts c) {
        for (std::size_t f = r.begin(); f != r.end(); ++f) {
          const std::int64_t g = neighbour[f];
          if (g < 0 || g < std::int64_t(f)) continue;  // boundary, or counted from g
          if (neighbour[std::size_t(g)] == std::int64_t(f)) {
            c[1] += parity(std::int64_t(f)) == parity(g);  // both tets on the same side
          } else {
            // A cycle of three or more, counted once: from its smallest face.
            bool smallest = true;
            for (std::int64_t h = g; h != std::int64_t(f) && smallest; h = neighbour[std::size_t(h)])
              smallest = h > std::int64_t(f);
            c[0] += smallest;
          }
        }
        return c;
      },
      [](Counts a, const Counts& b) { return Counts{a[0] + b[0], a[1] + b[1]}; });
  FaceUse use;
  use.shared_by_more_than_two = counts[0], use.overlapping = counts[1];
  for (std::size_t f = 0; f < neighbour.size(); ++f)
    if (neighbour[f] < 0) use.boundary.push_back(outward_faces(mesh.tets[f / 4])[f % 4]);
  return use;
}

Validity check_validity(const TetMesh& mesh) {
  Validity v;
  const FaceUse faces = classify_faces(mesh);  // throws on a bad vertex reference
  v.faces_shared_by_more_than_two = faces.shared_by_more_than_two;
  v.overlapping_faces = faces.overlapping;

  using Counts = std::array<std::size_t, 2>;  // inverted, zero volume
  const Counts counts = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh.tets.size(), 4096), Counts{0, 0},
      [&](const auto& r, Counts c) {
        for (std::size_t t = r.begin(); t != r.end(); ++t) {
          const Tet& tet = mesh.tets[t];
          double longest2 = 0;
          for (int i = 0; i < 4; ++i)
            for (int j = i + 1; j < 4; ++j)
              longest2 = std::max(longest2,
                                  squared_distance(mesh.vertices[tet[i]], mesh.vertices[tet[j]]));
          const double vol = signed_volume(mesh, tet);
          const bool repeated = tet[0] == tet[1] || tet[0] == tet[2] || tet[0] == tet[3] ||
                                tet[1] == tet[2] || tet[1] == tet[3] || tet[2] == tet[3];
          if (repeated || std::abs(vol) <= 1e-12 * longest2 * std::sqrt(longest2))
            ++c[1];
          else if (vol < 0)
            ++c[0];
        }
        return c;
      },
      [](Counts a, const Counts& b) {
        return Counts{a[0] + b[0], a[1] + b[1]};
      });
  v.inverted = counts[0], v.zero_volume = counts[1];

  std::vector<char> referenced(mesh.vertices.size(), 0);
  for (const Tet& t : mesh.tets)
    for (std::int32_t i : t) referenced[std::size_t(i)] = 1;
  v.unreferenced_vertices = std::size_t(std::count(referenced.begin(), referenced.end(), char(0)));

  v.boundary = surface_topology(faces.boundary, mesh.vertices.size());
  v.valid = !mesh.tets.empty() && v.inverted == 0 && v.zero_volume == 0 &&
            v.unreferenced_vertices == 0 && v.faces_shared_by_more_than_two == 0 &&
            v.overlapping_faces == 0 && v.boundary.closed_manifold;
  return v;
}

}  // namespace cvt
