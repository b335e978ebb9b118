// Stage 6, topological part: quality-driven flips after Shewchuk ("Two discrete optimization
// algorithms for the topological improvement of tetrahedral meshes", 2002) and Klingner &
// Shewchuk ("Aggressive tetrahedral mesh improvement", 2007): edge removal (the ring of tets
// around an interior edge re-triangulated by dynamic programming; 3-2 and 4-4 flips are its small
// cases), 2-3 face flips, boundary edge flips (the open fan of a convex boundary edge
// re-triangulated, which swaps the diagonal of the boundary quad; a flat tet lying on the
// boundary is simply removed) and corner removals. A change is made only when the smallest
// quality of the new tets is higher than that of the tets they replace, so the worst tet never
// gets worse. New tets are positively oriented and have the same boundary as the ones they
// replace (a boundary flip: less the convex tet it cuts off), so they fill that region: validity
// is kept by construction. Plans are made in parallel and applied in order, each only while the
// tets it replaces are unchanged.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "optimize/mesh_optimization_work.h"

namespace cvt::opt {
namespace {

struct Plan {
  enum Kind { none, edge_removal, face_flip, boundary_flip, corner_removal } kind = none;
  double new_min = -1;                 // smallest quality of the new tets
  std::vector<std::int32_t> old_tets;  // removed
  std::vector<Tet> old_content;        // … as they were when planned
  std::int32_t edge[2] = {-1, -1};     // new edge that must not exist yet (flip validity)
  bool edge_on_boundary_only = false;  // … only as a boundary edge (a fan of one tet)
  std::vector<Tet> new_tets;           // added
  std::vector<double> new_quality;
  std::int32_t label = 1;
  double shift_mm = 0;          // boundary flip: how far the boundary moves (mm)
  double face_distance_mm = 0;  // … and its new faces' distance to the surface
  double replaced_distance_mm = 0;  // … and the old faces', when the new are beyond tolerance
};

// The edges (i, j) of a tet, the two faces through each (opposite k, l).
constexpr int kEdges[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                              {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};

// The edges of tet t by how far their dihedral angle is from a regular tet's (cos θ = 1/3),
// farthest first: the edges whose removal helps (the two farthest win 85 % of the edge removals
// on the liver, the three farthest 91 %).
std::array<int, 6> edges_by_extremeness(const WorkMesh& m, const Tet& t) {
  const Vec3 &a = m.pos[t[0]], &b = m.pos[t[1]], &c = m.pos[t[2]], &d = m.pos[t[3]];
  Vec3 n[4] = {cross(c - b, d - b), cross(d - a, c - a), cross(b - a, d - a),
               cross(c - a, b - a)};  // outward
  for (Vec3& x : n) x = x / norm(x);
  std::array<double, 6> score;
  for (int e = 0; e < 6; ++e)
    score[e] = std::abs(-dot(n[kEdges[e][2]], n[kEdges[e][3]]) - 1.0 / 3.0);
  std::array<int, 6> order{0, 1, 2, 3, 4, 5};
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return score[x] > score[y]; });
  return order;
}

// Height of tet (p0, p1, p2, p3): 3V / largest face area (negative when inverted).
double tet_height(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const double vol6 = dot(p1 - p0, cross(p2 - p0, p3 - p0));
  const double max_area2 = std::max({norm(cross(p1 - p0, p2 - p0)), norm(cross(p1 - p0, p3 - p0)),
                                     norm(cross(p2 - p0, p3 - p0)), norm(cross(p2 - p1, p3 - p1))});
  return max_area2 > 0 ? vol6 / max_area2 : -1.0;
}

// Edge removal of (a, b): the tets around it are replaced by (a, tri) and (b, tri) for the
// triangles of the best triangulation of its ring polygon (dynamic programming: maximise the
// smallest new quality). For a boundary edge the polygon is the open fan closed by the edge
// ring.front()–ring.back(), whose two faces with a and b become the boundary: a flip of the
// boundary diagonal, allowed where the boundary is convex (the tet (a, b, front, back) is cut
// off, never added) and the new boundary follows the segmentation surface: its two faces'
// centroids and the midpoint of its new edge are within max_face_distance_mm of it, or no
// farther from it than the same points of the two faces replaced (a flat tet straddling the
// surface, whose removal moves the boundary from one side of it to the other); without the
// surface: the tet cut off is at most max_boundary_shift_mm high. A fan of one tet is simply
// removed.
void plan_edge_removal(const WorkMesh& m, std::int32_t a, std::int32_t b, const TopologyOptions& o,
                       Plan& best) {
  thread_local std::vector<std::int32_t> ring, ring_tets;  // scratch (this is hot)
  const WorkMesh::Ring kind = m.edge_ring(a, b, ring, ring_tets);
  if (kind == WorkMesh::Ring::none) return;
  const bool open = kind == WorkMesh::Ring::open;
  if (!(open ? o.boundary_flips : o.interior_flips)) return;
  constexpr int N = 16;  // largest ring the tables below hold
  const int n = int(ring.size());
  if (n > std::min(o.max_ring, N) || n < (open ? 2 : 3)) return;
  double old_min = std::numeric_limits<double>::infinity();
  for (std::int32_t t : ring_tets) {
    old_min = std::min(old_min, m.quality[t]);
    if (m.labels[t] != m.labels[ring_tets[0]]) return;
  }
  const double floor = std::max({old_min, best.new_min, kMinValidQuality});
  double shift = 0;
  if (open) {
    const std::int32_t front = ring.front(), back = ring.back();
    if (n == 2 ? m.is_boundary_edge(front, back) : m.has_edge(front, back)) return;
    shift = tet_height(m.pos[a], m.pos[b], m.pos[front], m.pos[back]);
    if (!(shift > 0)) return;  // concave: the boundary would move out, over unknown ground
    if (!o.surface && shift > o.max_boundary_shift_mm) return;
  }
  double Q[N][N];
  int choice[N][N];
  for (int i = 0; i + 1 < n; ++i) Q[i][i + 1] = std::numeric_limits<double>::infinity();
  for (int len = 2; len < n; ++len) {
    for (int i = 0; i + len < n; ++i) {
      const int k = i + len;
      Q[i][k] = -1;
      choice[i][k] = -1;
      for (int j = i + 1; j < k; ++j) {
        double q = std::min(Q[i][j], Q[j][k]);
        if (q <= Q[i][k] || q <= floor) continue;
        const Vec3 &ri = m.pos[ring[i]], &rj = m.pos[ring[j]], &rk = m.pos[ring[k]];
        q = std::min(q, m.tet_quality(m.pos[a], ri, rj, rk, std::max(Q[i][k], floor)));
        if (q <= Q[i][k] || q <= floor) continue;
        q = std::min(q, m.tet_quality(m.pos[b], ri, rk, rj, std::max(Q[i][k], floor)));
        if (q <= Q[i][k] || q <= floor) continue;
        Q[i][k] = q;
        choice[i][k] = j;
      }
    }
  }
  const double result = n >= 2 ? Q[0][n - 1] : -1.0;
  if (!(result > floor)) return;
  double face_distance = 0, replaced = 0;
  if (open && o.surface) {
    // The new boundary faces must follow the surface: their centroids and the midpoint of the
    // new boundary edge (where a cut is deepest) within max_face_distance_mm of it, or no
    // farther than the same points of the faces they replace (then the boundary follows the
    // surface no worse than before: a flat tet that straddles it may go).
    const Vec3 &pa = m.pos[a], &pb = m.pos[b], &front = m.pos[ring.front()],
               &back = m.pos[ring.back()];
    const auto farthest = [&](const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& s) {
      double d = 0;
      for (const Vec3& x : {(p + q) * 0.5, (p + q + r) / 3.0, (p + q + s) / 3.0})
        d = std::max(d, o.surface->distance(x));
      return d;
    };
    face_distance = farthest(front, back, pa, pb);
    if (face_distance > o.max_face_distance_mm) {
      replaced = farthest(pa, pb, front, back);
      if (face_distance > replaced) return;
    }
  }
  best.kind = open ? Plan::boundary_flip : Plan::edge_removal;
  best.face_distance_mm = face_distance;
  best.replaced_distance_mm = replaced;
  best.edge[0] = open ? ring.front() : -1;
  best.edge[1] = open ? ring.back() : -1;
  best.edge_on_boundary_only = n == 2;
  best.new_min = result;
  best.old_tets = ring_tets;
  best.label = m.labels[ring_tets[0]];
  best.shift_mm = shift;
  best.new_tets.clear();
  best.new_quality.clear();
  // Unwind the choices (explicit stack).
  std::vector<std::array<int, 2>> stack{{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, k] = stack.back();
    stack.pop_back();
    if (k - i < 2) continue;
    const int j = choice[i][k];
    const Tet ta{a, ring[i], ring[j], ring[k]}, tb{b, ring[i], ring[k], ring[j]};
    best.new_tets.push_back(ta);
    best.new_quality.push_back(m.tet_quality(ta));
    best.new_tets.push_back(tb);
    best.new_quality.push_back(m.tet_quality(tb));
    stack.push_back({i, j});
    stack.push_back({j, k});
  }
}

// 2-3 flip of face `f` of tet `t` (the face opposite t[f]).
void plan_face_flip(const WorkMesh& m, std::int32_t t, int f, Plan& best) {
  const Tet& tet = m.tets[t];
  const Triangle face = outward_faces(tet)[f];
  thread_local std::vector<std::int32_t> sharing;
  m.tets_with(face.data(), 3, sharing);
  if (sharing.size() != 2) return;  // a boundary face
  const std::int32_t other = sharing[0] == t ? sharing[1] : sharing[0];
  if (m.labels[other] != m.labels[t]) return;
  const Tet& o = m.tets[other];
  std::int32_t e = -1;
  for (std::int32_t v : o)
    if (v != face[0] && v != face[1] && v != face[2]) e = v;
  const std::int32_t d = tet[f];
  if (m.has_edge(d, e)) return;  // the new edge exists elsewhere (cannot be in a valid result)
  const double old_min = std::min(m.quality[t], m.quality[other]);
  const double floor = std::max({old_min, best.new_min, kMinValidQuality});
  // The face's normal points away from d, towards e: (d, e, x, y) is positive around (d, e).
  const std::array<Tet, 3> nt{Tet{d, e, face[0], face[1]}, Tet{d, e, face[1], face[2]},
                              Tet{d, e, face[2], face[0]}};
  std::array<double, 3> q{};
  double new_min = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    q[i] = m.tet_quality(nt[i]);
    new_min = std::min(new_min, q[i]);
    if (new_min <= floor) return;
  }
  best.kind = Plan::face_flip;
  best.new_min = new_min;
  best.edge[0] = d;
  best.edge[1] = e;
  best.edge_on_boundary_only = false;
  best.old_tets = {t, other};
  best.new_tets.assign(nt.begin(), nt.end());
  best.new_quality.assign(q.begin(), q.end());
  best.label = m.labels[t];
}

// Removal of a corner: tet t has three boundary faces around a vertex p that has no other tet
// (a spike of four surface samples, flat where the surface is). The tet and p go; the fourth
// face becomes boundary, when it follows the segmentation surface (its centroid within
// max_face_distance_mm; without the surface: the tet is at most max_boundary_shift_mm high).
void plan_corner_removal(const WorkMesh& m, std::int32_t t, const TopologyOptions& o, Plan& best) {
  const Tet& tet = m.tets[t];
  thread_local std::vector<std::int32_t> sharing;
  const auto faces = outward_faces(tet);
  int interior = -1, boundary_faces = 0;
  for (int f = 0; f < 4; ++f) {
    m.tets_with(faces[f].data(), 3, sharing);
    if (sharing.size() == 1)
      ++boundary_faces;
    else
      interior = f;
  }
  if (boundary_faces != 3 || interior < 0) return;
  const std::int32_t p = tet[interior];  // the corner: opposite the interior face
  if (m.vertex_tets[p].size() != 1) return;
  const Triangle& base = faces[interior];
  const Vec3 &x = m.pos[base[0]], &y = m.pos[base[1]], &z = m.pos[base[2]];
  const double height = tet_height(m.pos[tet[0]], m.pos[tet[1]], m.pos[tet[2]], m.pos[tet[3]]);
  double distance = 0;
  if (o.surface) {
    distance = o.surface->distance((x + y + z) / 3.0);
    if (distance > o.max_face_distance_mm) return;
  } else if (height > o.max_boundary_shift_mm) {
    return;
  }
  best.kind = Plan::corner_removal;
  best.new_min = std::numeric_limits<double>::infinity();
  best.old_tets = {t};
  best.new_tets.clear();
  best.new_quality.clear();
  best.shift_mm = height;
  best.face_distance_mm = distance;
  best.edge[0] = best.edge[1] = -1;
}

}  // namespace

PassCounts improve_topology(WorkMesh& m, const TopologyOptions& options) {
  PassCounts counts;
  std::vector<std::pair<double, std::int32_t>> bad;
  std::vector<Plan> plans;
  constexpr std::size_t kChunk = 128;  // tets planned together
  for (int round = 0; round < options.max_rounds; ++round) {
    // The bad tets whose neighbourhood changed since they last failed, worst first.
    bad.clear();
    for (std::size_t t = 0; t < m.tets.size(); ++t)
      if (!is_dead(m.tets[t]) && m.quality[t] < options.bad_below &&
          m.changed_since(std::int32_t(t), m.flip_failed[t]))
        bad.push_back({m.quality[t], std::int32_t(t)});
    if (bad.empty()) break;
    std::sort(bad.begin(), bad.end());
    std::size_t changes = 0;
    // In chunks: plans for a chunk are made in parallel on the mesh as it is, then applied in
    // order, each only while the tets it replaces are as planned (else the tet is tried again
    // in the next round). The result does not depend on the thread count.
    for (std::size_t first = 0; first < bad.size(); first += kChunk) {
      m.check_cancelled();
      const std::size_t count = std::min(kChunk, bad.size() - first);
      const std::uint64_t planned_at = m.clock;
      plans.assign(count, Plan{});
      tbb::parallel_for(std::size_t(0), count, [&](std::size_t k) {
        const std::int32_t t = bad[first + k].second;
        if (is_dead(m.tets[t]) || m.quality[t] >= options.bad_below) return;
        Plan& plan = plans[k];
        plan.kind = Plan::none;
        if (options.boundary_flips) plan_corner_removal(m, t, options, plan);
        if (plan.kind == Plan::corner_removal) {
          plan.old_content.push_back(m.tets[t]);
          return;
        }
        const Tet tet = m.tets[t];
        const auto order = edges_by_extremeness(m, tet);
        for (int r = 0; r < options.edges_tried; ++r)
          plan_edge_removal(m, tet[kEdges[order[r]][0]], tet[kEdges[order[r]][1]], options, plan);
        // 2-3 flips rarely beat an edge removal (9 of 18k on the liver's first pass): only
        // when no edge removal helps.
        if (options.interior_flips && plan.kind == Plan::none)
          for (int f = 0; f < 4; ++f) plan_face_flip(m, t, f, plan);
        if (plan.kind == Plan::none) plan.new_min = -2;  // tried, nothing found
        for (std::int32_t old : plan.old_tets) plan.old_content.push_back(m.tets[old]);
      });
      for (std::size_t k = 0; k < count; ++k) {
        const std::int32_t t = bad[first + k].second;
        const Plan& plan = plans[k];
        if (plan.kind == Plan::none) {
          if (plan.new_min == -2) m.flip_failed[t] = planned_at;
          continue;
        }
        bool valid = true;
        for (std::size_t i = 0; i < plan.old_tets.size() && valid; ++i)
          valid = m.tets[plan.old_tets[i]] == plan.old_content[i];
        if (valid && plan.edge[0] >= 0)
          valid = plan.edge_on_boundary_only ? !m.is_boundary_edge(plan.edge[0], plan.edge[1])
                                             : !m.has_edge(plan.edge[0], plan.edge[1]);
        if (!valid) continue;
        for (std::int32_t old : plan.old_tets) m.remove_tet(old);
        for (std::size_t i = 0; i < plan.new_tets.size(); ++i)
          m.add_tet(plan.new_tets[i], plan.label, plan.new_quality[i]);
        ++changes;
        switch (plan.kind) {
          case Plan::edge_removal:
            ++counts.edge_removals;
            break;
          case Plan::face_flip:
            ++counts.face_flips;
            break;
          case Plan::boundary_flip:
            ++counts.boundary_flips;
            counts.max_boundary_shift_mm = std::max(counts.max_boundary_shift_mm, plan.shift_mm);
            counts.max_face_distance_mm =
                std::max(counts.max_face_distance_mm, plan.face_distance_mm);
            counts.max_replaced_distance_mm =
                std::max(counts.max_replaced_distance_mm, plan.replaced_distance_mm);
            break;
          case Plan::corner_removal:
            ++counts.corner_removals;
            counts.max_boundary_shift_mm = std::max(counts.max_boundary_shift_mm, plan.shift_mm);
            counts.max_face_distance_mm =
                std::max(counts.max_face_distance_mm, plan.face_distance_mm);
            break;
          case Plan::none:
            break;
        }
      }
    }
    if (changes == 0) break;
  }
  return counts;
}

}  // namespace cvt::opt
