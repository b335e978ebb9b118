// Edge collapse for needles and wedges: a bad tet with an edge (u, v) much shorter than its
// longest (two samples that landed close together, a snapped vertex beside a surface sample,
// a tiny boundary triangle under a far vertex) cannot be mended by flips or moves, since every
// tet around the edge is as bad. Removing v and joining its star to u removes the edge. A
// collapse is made only when
//   - it keeps the topology: the link condition (the vertices and triangles u and v both see are
//     exactly those around the edge, the boundary counted as one more vertex seen by every
//     boundary vertex),
//   - it keeps the boundary: v interior, or u and v both on the boundary and the edge on it, and
//     then every new boundary triangle stays within the fidelity bound of the surface,
//   - the worst new tet is better than the worst one it replaces (and positively oriented).
// Sequential, worst tets first: deterministic.
#include <algorithm>
#include <array>
#include <iterator>
#include <limits>
#include <set>
#include <utility>

#include "optimize/mesh_optimization_work.h"

namespace cvt::opt {
namespace {

constexpr std::int32_t kOutside = -1;  // the boundary as a vertex of the links

// Neighbours of vertex a (the other vertices of its tets), and kOutside when it is on the
// boundary.
std::set<std::int32_t> neighbours(const WorkMesh& m, std::int32_t a) {
  std::set<std::int32_t> n;
  for (std::int32_t t : m.vertex_tets[a])
    for (std::int32_t w : m.tets[t])
      if (w != a) n.insert(w);
  if (m.on_boundary[a]) n.insert(kOutside);
  return n;
}

// The triangles of a's link as sorted vertex pairs: (w1, w2) for each face (a, w1, w2), with
// (w, kOutside) for each boundary edge (a, w).
std::set<std::pair<std::int32_t, std::int32_t>> link_edges(const WorkMesh& m, std::int32_t a) {
  std::set<std::pair<std::int32_t, std::int32_t>> e;
  for (std::int32_t t : m.vertex_tets[a]) {
    std::array<std::int32_t, 3> o{};
    int k = 0;
    for (std::int32_t w : m.tets[t])
      if (w != a) o[k++] = w;
    for (int i = 0; i < 3; ++i) {
      const std::int32_t x = o[i], y = o[(i + 1) % 3];
      e.insert({std::min(x, y), std::max(x, y)});
    }
  }
  if (m.on_boundary[a])
    for (std::int32_t w : neighbours(m, a))
      if (w != kOutside && m.is_boundary_edge(a, w)) e.insert({kOutside, w});
  return e;
}

bool link_condition(const WorkMesh& m, std::int32_t u, std::int32_t v) {
  std::vector<std::int32_t> ring, ring_tets;
  const WorkMesh::Ring kind = m.edge_ring(u, v, ring, ring_tets);
  if (kind == WorkMesh::Ring::none) return false;
  std::set<std::int32_t> around(ring.begin(), ring.end());
  std::set<std::pair<std::int32_t, std::int32_t>> around_edges;
  const std::size_t n = ring.size();
  for (std::size_t i = 0; i + 1 < n; ++i)
    around_edges.insert({std::min(ring[i], ring[i + 1]), std::max(ring[i], ring[i + 1])});
  if (kind == WorkMesh::Ring::closed) {
    around_edges.insert({std::min(ring[n - 1], ring[0]), std::max(ring[n - 1], ring[0])});
  } else {
    around.insert(kOutside);
    around_edges.insert({kOutside, ring.front()});
    around_edges.insert({kOutside, ring.back()});
  }
  const std::set<std::int32_t> nu = neighbours(m, u), nv = neighbours(m, v);
  std::set<std::int32_t> common;
  std::set_intersection(nu.begin(), nu.end(), nv.begin(), nv.end(),
                        std::inserter(common, common.begin()));
  if (common != around) return false;
  const auto eu = link_edges(m, u), ev = link_edges(m, v);
  std::set<std::pair<std::int32_t, std::int32_t>> common_edges;
  std::set_intersection(eu.begin(), eu.end(), ev.begin(), ev.end(),
                        std::inserter(common_edges, common_edges.begin()));
  return common_edges == around_edges;
}

struct Collapse {
  std::vector<std::int32_t> removed;            // every tet of v's star
  std::vector<std::pair<Tet, std::int32_t>> added;  // (tet, label) with v replaced by u
  std::vector<double> quality;                  // of the added tets
};

// v merged into u (u keeps its place), when that is allowed and raises the worst tet above
// `worst` (the worst of v's star).
bool plan_collapse(const WorkMesh& m, std::int32_t u, std::int32_t v,
                   const LevelSetSurface* surface, double max_face_distance_mm, Collapse& c) {
  if (m.on_boundary[v] && !(m.on_boundary[u] && m.is_boundary_edge(u, v))) return false;
  if (m.on_boundary[v] && !surface) return false;  // the boundary may move only near a surface
  if (!link_condition(m, u, v)) return false;
  c = {};
  double worst = std::numeric_limits<double>::infinity();
  for (std::int32_t t : m.vertex_tets[v]) {
    worst = std::min(worst, m.quality[t]);
    c.removed.push_back(t);
    const Tet& tet = m.tets[t];
    if (std::find(tet.begin(), tet.end(), u) != tet.end()) continue;
    Tet nt = tet;
    for (std::int32_t& w : nt)
      if (w == v) w = u;
    c.added.push_back({nt, m.labels[t]});
  }
  for (const auto& [nt, label] : c.added) {
    const double q = m.tet_quality(m.pos[nt[0]], m.pos[nt[1]], m.pos[nt[2]], m.pos[nt[3]], worst);
    if (!(q > worst) || q <= 0) return false;
    c.quality.push_back(q);
  }
  if (m.on_boundary[v]) {
    // The new boundary triangles: those of v's star with v replaced, off the removed tets.
    for (const auto& [nt, label] : c.added) {
      for (int i = 0; i < 4; ++i) {
        if (nt[i] == u) continue;  // the face opposite u does not hold u: it existed before
        std::array<std::int32_t, 3> f{};
        int k = 0;
        for (int j = 0; j < 4; ++j)
          if (j != i) f[k++] = nt[j];
        std::array<std::int32_t, 3> old = f;
        for (std::int32_t& w : old)
          if (w == u) w = v;
        std::vector<std::int32_t> users;
        m.tets_with(old.data(), 3, users);
        if (users.size() != 1) continue;  // an interior face before: interior after
        const Vec3 centroid = (m.pos[f[0]] + m.pos[f[1]] + m.pos[f[2]]) * (1.0 / 3.0);
        if (surface->distance(centroid) > max_face_distance_mm) return false;
      }
    }
  }
  return true;
}

// The edges of t at most `ratio` × its longest one, shortest first: a needle's short edge, and
// each edge of a small triangle under a far vertex (a wedge: three vertices close together,
// whose shortest edge is not much shorter than the next).
int short_edges(const WorkMesh& m, const Tet& t, double ratio,
                std::array<std::pair<std::int32_t, std::int32_t>, 6>& out) {
  std::array<std::pair<double, int>, 6> edges;
  int k = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) edges[k] = {norm(m.pos[t[i]] - m.pos[t[j]]), 4 * i + j}, ++k;
  std::sort(edges.begin(), edges.end());
  int n = 0;
  for (const auto& [length, code] : edges)
    if (length <= ratio * edges[5].first) out[n++] = {t[code / 4], t[code % 4]};
  return n;
}

}  // namespace

PassCounts collapse_short_edges(WorkMesh& m, const CollapseOptions& o) {
  PassCounts counts;
  std::vector<std::pair<double, std::int32_t>> bad;
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    if (!is_dead(m.tets[t]) && m.quality[t] < o.bad_below)
      bad.push_back({m.quality[t], std::int32_t(t)});
  std::sort(bad.begin(), bad.end());
  Collapse c;
  for (const auto& [q, t] : bad) {
    const Tet tet = m.tets[t];
    if (is_dead(tet) || m.quality[t] != q) continue;  // changed by an earlier collapse
    std::array<std::pair<std::int32_t, std::int32_t>, 6> edges;
    const int n = short_edges(m, tet, o.max_length_ratio, edges);
    auto keeps = [&](std::int32_t w) {
      return 2 * int(m.on_boundary[w]) + int(!m.on_surface.empty() && m.on_surface[w]);
    };
    bool collapsed = false;
    for (int e = 0; e < n && !collapsed; ++e) {
      const auto [a, b] = edges[e];
      // Keep the vertex that is on the surface (or on the boundary) where there is a choice.
      std::array<std::pair<std::int32_t, std::int32_t>, 2> tries{{{a, b}, {b, a}}};
      if (keeps(b) > keeps(a)) std::swap(tries[0], tries[1]);
      for (const auto& [u, v] : tries) {
        if (!plan_collapse(m, u, v, o.surface, o.max_face_distance_mm, c)) continue;
        for (std::int32_t r : c.removed) m.remove_tet(r);
        for (std::size_t i = 0; i < c.added.size(); ++i)
          m.add_tet(c.added[i].first, c.added[i].second, c.quality[i]);
        ++counts.collapsed_edges;
        collapsed = true;
        break;
      }
    }
  }
  return counts;
}

}  // namespace cvt::opt
