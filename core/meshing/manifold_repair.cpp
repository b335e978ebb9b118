#include "meshing/manifold_repair.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

namespace cvt {
namespace {

using Edge = std::pair<std::int32_t, std::int32_t>;

// signed_volume of a tet over a point list (no TetMesh to copy them into).
double volume_of(const std::vector<Vec3>& p, const Tet& t) {
  return dot(p[t[1]] - p[t[0]], cross(p[t[2]] - p[t[0]], p[t[3]] - p[t[0]])) / 6.0;
}
Edge edge(std::int32_t a, std::int32_t b) { return a < b ? Edge{a, b} : Edge{b, a}; }

// Vertex → incident tets (CSR), over the tets still alive.
struct Star {
  std::vector<std::size_t> start;
  std::vector<std::int32_t> tets;
  Star(std::size_t vertex_count, const std::vector<Tet>& all) : start(vertex_count + 1, 0) {
    for (const Tet& t : all)
      for (std::int32_t v : t) ++start[v + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    tets.resize(start.back());
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < all.size(); ++i)
      for (std::int32_t v : all[i]) tets[fill[v]++] = std::int32_t(i);
  }
};

int shared_vertices(const Tet& a, const Tet& b) {
  int n = 0;
  for (std::int32_t x : a) n += std::count(b.begin(), b.end(), x);
  return n;
}

// Splits `group` (tet indices) into classes connected through shared faces (3 shared vertices),
// returns the class id of each member; classes are numbered from 0.
std::vector<int> fan_classes(const std::vector<Tet>& tets, const std::vector<std::int32_t>& group,
                             int& count) {
  std::vector<int> cls(group.size(), -1);
  count = 0;
  for (std::size_t s = 0; s < group.size(); ++s) {
    if (cls[s] >= 0) continue;
    std::vector<std::size_t> stack{s};
    cls[s] = count;
    while (!stack.empty()) {
      const std::size_t a = stack.back();
      stack.pop_back();
      for (std::size_t b = 0; b < group.size(); ++b)
        if (cls[b] < 0 && shared_vertices(tets[group[a]], tets[group[b]]) == 3) {
          cls[b] = count;
          stack.push_back(b);
        }
    }
    ++count;
  }
  return cls;
}

// Marks for removal every tet of `group` outside its largest fan; returns how many it newly
// marked (others may be marked already). `fans` receives the number of fans.
std::size_t keep_largest_fan(const std::vector<Tet>& tets, const std::vector<std::int32_t>& group,
                             std::vector<char>& remove, int* fans = nullptr) {
  int count = 0;
  const std::vector<int> cls = fan_classes(tets, group, count);
  if (fans) *fans = count;
  if (count < 2) return 0;
  std::vector<int> size(count, 0);
  for (int c : cls) ++size[c];
  const int keep = int(std::max_element(size.begin(), size.end()) - size.begin());  // first max
  std::size_t removed = 0;
  for (std::size_t i = 0; i < group.size(); ++i)
    if (cls[i] != keep && !remove[group[i]]) {
      remove[group[i]] = 1;
      ++removed;
    }
  return removed;
}

// True when the link edges (the far edges of the boundary triangles around a vertex) form a
// single closed cycle, i.e. the boundary is a disc around the vertex. Links have a handful of
// edges, so quadratic scans beat any map (this runs for every boundary vertex, every pass).
bool link_is_one_cycle(const Edge* l, std::size_t m) {
  // Every link vertex must have exactly two link edges.
  for (std::size_t e = 0; e < m; ++e)
    for (const std::int32_t x : {l[e].first, l[e].second}) {
      int degree = 0;
      for (std::size_t f = 0; f < m; ++f) degree += (l[f].first == x) + (l[f].second == x);
      if (degree != 2) return false;
    }
  // Then the link is a union of cycles: walk the one through edge 0 and count its edges.
  std::vector<char> used(m, 0);
  used[0] = 1;
  std::size_t visited = 1;
  for (std::int32_t cur = l[0].second; cur != l[0].first; ++visited) {
    std::size_t f = 0;
    while (used[f] || (l[f].first != cur && l[f].second != cur)) ++f;
    used[f] = 1;
    cur = l[f].first == cur ? l[f].second : l[f].first;
  }
  return visited == m;
}

// How many boundary triangles use each edge, in edge order (a sorted list, not a map: the
// liver's boundary has ~150k edge uses).
std::vector<std::pair<Edge, int>> count_edge_use(const std::vector<Triangle>& boundary) {
  std::vector<Edge> edges;
  edges.reserve(3 * boundary.size());
  for (const Triangle& f : boundary)
    for (int k = 0; k < 3; ++k) edges.push_back(edge(f[k], f[(k + 1) % 3]));
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<Edge, int>> use;
  for (const Edge& e : edges) {
    if (use.empty() || use.back().first != e) use.push_back({e, 0});
    ++use.back().second;
  }
  return use;
}

// Boundary link of every vertex (CSR: vertex v's link edges are edges[start[v]..start[v+1])).
struct BoundaryLinks {
  std::vector<std::size_t> start;
  std::vector<Edge> edges;
  BoundaryLinks(const std::vector<Triangle>& boundary, std::size_t vertex_count)
      : start(vertex_count + 1, 0), edges(3 * boundary.size()) {
    for (const Triangle& f : boundary)
      for (int k = 0; k < 3; ++k) ++start[f[k] + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (const Triangle& f : boundary)
      for (int k = 0; k < 3; ++k) edges[fill[f[k]]++] = edge(f[(k + 1) % 3], f[(k + 2) % 3]);
  }
  // False for a vertex off the boundary.
  bool pinched(std::size_t v) const {
    const std::size_t m = start[v + 1] - start[v];
    return m > 0 && !link_is_one_cycle(edges.data() + start[v], m);
  }
};

}  // namespace

bool is_flat_tet(const std::vector<Vec3>& points, const Tet& t) {
  const double v = std::abs(volume_of(points, t));
  double longest = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) longest = std::max(longest, distance(points[t[i]], points[t[j]]));
  return v <= 1e-9 * longest * longest * longest;
}

bool link_is_pinched(const std::vector<Edge>& link) {
  return !link.empty() && !link_is_one_cycle(link.data(), link.size());
}

std::vector<std::int32_t> pinched_vertices(std::size_t vertex_count,
                                           const std::vector<Triangle>& boundary) {
  const BoundaryLinks links(boundary, vertex_count);
  std::vector<std::int32_t> pinched;
  for (std::size_t v = 0; v < vertex_count; ++v)
    if (links.pinched(v)) pinched.push_back(std::int32_t(v));
  return pinched;
}

ManifoldRepairReport repair_boundary_manifold(const std::vector<Vec3>& points,
                                              std::vector<Tet>& tets,
                                              std::vector<std::array<Vec3, 4>>* removed_out) {
  ManifoldRepairReport report;
  for (;; ++report.passes) {
    std::vector<Triangle> boundary;
    const std::vector<std::int64_t> neighbour = face_neighbours(points.size(), tets);
    for (std::size_t f = 0; f < neighbour.size(); ++f)
      if (neighbour[f] < 0) boundary.push_back(outward_faces(tets[f / 4])[f % 4]);
    std::vector<char> remove(tets.size(), 0);
    const Star star(points.size(), tets);

    // Boundary faces per edge (in edge order), and the boundary link of every vertex.
    const std::vector<std::pair<Edge, int>> edge_use = count_edge_use(boundary);
    const BoundaryLinks links(boundary, points.size());

    // 1. Flat tets with a face on the boundary.
    std::size_t changed = 0;
    for (const Triangle& f : boundary)
      for (std::int32_t t : std::vector<std::int32_t>(star.tets.begin() + star.start[f[0]],
                                                      star.tets.begin() + star.start[f[0] + 1])) {
        if (remove[t] || shared_vertices(tets[t], {f[0], f[1], f[2], -1}) != 3) continue;
        if (is_flat_tet(points, tets[t])) {
          remove[t] = 1;
          ++report.flat_removed;
          ++changed;
        }
      }
    // 2. Edges with more than two boundary faces: tets around them form several fans.
    for (const auto& [e, use] : edge_use) {
      if (use == 2) continue;
      std::vector<std::int32_t> group;
      for (std::size_t s = star.start[e.first]; s < star.start[e.first + 1]; ++s) {
        const Tet& t = tets[star.tets[s]];
        if (std::find(t.begin(), t.end(), e.second) != t.end()) group.push_back(star.tets[s]);
      }
      const std::size_t n = keep_largest_fan(tets, group, remove);
      report.edge_fans_removed += n;
      changed += n;
    }
    // 3. Vertices whose boundary link is not one cycle: the star has several fans.
    for (std::size_t v = 0; v < points.size(); ++v) {
      if (!links.pinched(v)) continue;
      const std::vector<std::int32_t> group(star.tets.begin() + star.start[v],
                                            star.tets.begin() + star.start[v + 1]);
      int fans = 0;
      std::size_t n = keep_largest_fan(tets, group, remove, &fans);
      if (fans == 1) {
        // One fan of tets, yet the empty space around v has several parts (two concavities
        // touch at v): removing v's star merges them.
        for (std::int32_t t : group)
          if (!remove[t]) {
            remove[t] = 1;
            ++n;
          }
      }
      report.vertex_fans_removed += n;
      changed += n;
    }
    if (!changed) {
      report.manifold = true;
      for (const auto& [e, use] : edge_use) report.manifold &= use == 2;
      return report;
    }
    std::vector<Tet> kept;
    kept.reserve(tets.size());
    for (std::size_t t = 0; t < tets.size(); ++t) {
      if (!remove[t]) {
        kept.push_back(tets[t]);
      } else if (removed_out) {
        removed_out->push_back({points[tets[t][0]], points[tets[t][1]], points[tets[t][2]],
                                points[tets[t][3]]});
      }
    }
    tets.swap(kept);
    if (report.passes > 50) return report;  // does not happen in practice; report says so
  }
}

}  // namespace cvt

namespace cvt {

std::size_t remove_small_tet_components(const std::vector<Vec3>& points, std::vector<Tet>& tets,
                                        double fraction,
                                        std::vector<std::array<Vec3, 4>>* removed_out) {
  if (tets.empty()) return 0;
  // Union tets that share a face.
  const std::vector<std::int64_t> neighbour = face_neighbours(points.size(), tets);
  std::vector<std::int32_t> parent(tets.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t f = 0; f < neighbour.size(); ++f)
    if (neighbour[f] >= 0) {
      const std::int32_t a = find(std::int32_t(f / 4)), b = find(std::int32_t(neighbour[f] / 4));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<std::int32_t> component(tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t) component[t] = find(std::int32_t(t));
  return remove_small_tet_components(points, tets, component, fraction, removed_out);
}

std::size_t remove_small_tet_components(const std::vector<Vec3>& points, std::vector<Tet>& tets,
                                        const std::vector<std::int32_t>& component,
                                        double fraction,
                                        std::vector<std::array<Vec3, 4>>* removed_out) {
  if (tets.empty()) return 0;
  // Volumes summed in fixed point (the largest tet near 2^30 units), exact in any order, so the
  // result depends neither on the order of the tets nor on how components are numbered.
  std::vector<double> tet_volume(tets.size());
  double biggest = 0;
  for (std::size_t t = 0; t < tets.size(); ++t)
    biggest = std::max(biggest, std::abs(tet_volume[t] = volume_of(points, tets[t])));
  const double unit = biggest > 0 ? std::ldexp(1.0, 30 - std::ilogb(biggest)) : 1.0;
  std::vector<std::int64_t> volume(
      std::size_t(*std::max_element(component.begin(), component.end())) + 1, 0);
  for (std::size_t t = 0; t < tets.size(); ++t)
    volume[component[t]] += std::llround(tet_volume[t] * unit);
  const double largest = double(*std::max_element(volume.begin(), volume.end()));
  std::vector<Tet> kept;
  kept.reserve(tets.size());
  for (std::size_t t = 0; t < tets.size(); ++t) {
    if (double(volume[component[t]]) >= fraction * largest) {
      kept.push_back(tets[t]);
    } else if (removed_out) {
      removed_out->push_back({points[tets[t][0]], points[tets[t][1]], points[tets[t][2]],
                              points[tets[t][3]]});
    }
  }
  const std::size_t removed = tets.size() - kept.size();
  tets.swap(kept);
  return removed;
}

}  // namespace cvt
