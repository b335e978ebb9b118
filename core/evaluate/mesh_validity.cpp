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

// One face of one tet, in the bucket of its smallest vertex, keyed by the other two.
struct FaceRecord {
  std::uint64_t key;     // middle and largest vertex index
  std::uint32_t face;    // 4 · tet + local face
  std::uint32_t parity;  // 1 when the outward face is an odd permutation of the sorted vertices
};

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
  // Faces bucketed by their smallest vertex (counting sort); a bucket holds the few faces around
  // one vertex, matched by the other two vertices.
  std::vector<std::uint32_t> start(nv + 1, 0);
  for (const Tet& t : mesh.tets)
    for (const Triangle& f : outward_faces(t))
      ++start[std::size_t(std::min({f[0], f[1], f[2]})) + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<FaceRecord> faces(4 * n);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t t = 0; t < n; ++t) {
      const auto outward = outward_faces(mesh.tets[t]);
      for (std::size_t f = 0; f < 4; ++f) {
        std::array<std::int32_t, 3> v = outward[f];
        const std::uint32_t parity = sort3(v);
        const std::uint64_t key = (std::uint64_t(std::uint32_t(v[1])) << 32) | std::uint32_t(v[2]);
        faces[fill[std::size_t(v[0])]++] = {key, std::uint32_t(4 * t + f), parity};
      }
    }
  }
  // Per bucket: sort by key (ties by tet, so the result does not depend on scheduling) and
  // classify each run of equal keys. Boundary faces are flagged by their (tet, face) id.
  std::vector<char> once(4 * n, 0);
  using Counts = std::array<std::size_t, 2>;  // shared by more than two, overlapping
  const Counts counts = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, nv, 1024), Counts{0, 0},
      [&](const auto& r, Counts c) {
        for (std::size_t v = r.begin(); v != r.end(); ++v) {
          const auto first = faces.begin() + start[v], last = faces.begin() + start[v + 1];
          std::sort(first, last, [](const FaceRecord& a, const FaceRecord& b) {
            return a.key != b.key ? a.key < b.key : a.face < b.face;
          });
          for (auto run = first; run != last;) {
            auto end = run + 1;
            while (end != last && end->key == run->key) ++end;
            if (end - run == 1)
              once[run->face] = 1;
            else if (end - run == 2)
              c[1] += run->parity == (run + 1)->parity;
            else
              ++c[0];
            run = end;
          }
        }
        return c;
      },
      [](Counts a, const Counts& b) {
        return Counts{a[0] + b[0], a[1] + b[1]};
      });
  FaceUse use;
  use.shared_by_more_than_two = counts[0], use.overlapping = counts[1];
  for (std::size_t f = 0; f < once.size(); ++f)
    if (once[f]) use.boundary.push_back(outward_faces(mesh.tets[f / 4])[f % 4]);
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
