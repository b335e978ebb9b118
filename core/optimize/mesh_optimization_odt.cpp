// Stage 6, global part: ODT smoothing of the interior vertices (each moved towards the
// volume-weighted mean of its tets' circumcentres, Chen & Xu 2004, Alliez et al. 2005), kept only
// where no tet turns bad and no bad tet gets worse; optionally followed by Lawson flips towards
// a Delaunay mesh. Vertex moves run by colour classes in parallel (shared with the smoothing of
// bad tets), so the result does not depend on the thread count.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "optimize/mesh_optimization_work.h"

namespace cvt::opt {
namespace {

// ODT position of interior vertex v: the volume-weighted mean of its tets' circumcentres
// (Chen & Xu; Alliez et al. 2005), then the longest step towards it (1, ½, ¼) after which no
// tet of the star is bad unless it was before, and the star's worst tet is no worse.
Move odt_move(const WorkMesh& m, std::int32_t v, double* star_quality) {
  const std::vector<std::int32_t>& star = m.vertex_tets[v];
  Vec3 sum{0, 0, 0};
  double volume = 0;
  double old_min = std::numeric_limits<double>::infinity();
  for (std::int32_t t : star) {
    const Tet& tet = m.tets[t];
    const Vec3 &a = m.pos[tet[0]], &b = m.pos[tet[1]], &c = m.pos[tet[2]], &d = m.pos[tet[3]];
    const Vec3 ab = b - a, ac = c - a, ad = d - a;
    const double vol6 = dot(ab, cross(ac, ad));
    const Vec3 rel =
        (cross(ac, ad) * dot(ab, ab) + cross(ad, ab) * dot(ac, ac) + cross(ab, ac) * dot(ad, ad)) /
        (2.0 * vol6);
    sum += (a + rel) * vol6;
    volume += vol6;
    old_min = std::min(old_min, m.quality[t]);
  }
  const Vec3 x0 = m.pos[v];
  if (!(volume > 0)) return {x0, false};
  const Vec3 target = sum / volume;
  if (!std::isfinite(target.x + target.y + target.z)) return {x0, false};
  const double floor = std::max(std::min(old_min, 1.0), kMinValidQuality);
  for (double w = 1.0; w > 0.2; w *= 0.5) {
    const Vec3 y = x0 + (target - x0) * w;
    bool ok = true;
    for (std::size_t i = 0; i < star.size() && ok; ++i) {
      star_quality[i] = quality_at(m, star[i], v, y, floor);
      ok = star_quality[i] > floor;
    }
    if (ok) return {y, true};
  }
  return {x0, false};
}

// Whether p lies strictly inside the circumsphere of tet (a, b, c, d) (positively oriented).
bool in_circumsphere(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& p) {
  const Vec3 ab = b - a, ac = c - a, ad = d - a;
  const double vol6 = dot(ab, cross(ac, ad));
  if (!(vol6 > 0)) return false;
  const Vec3 rel =
      (cross(ac, ad) * dot(ab, ab) + cross(ad, ab) * dot(ac, ac) + cross(ab, ac) * dot(ad, ad)) /
      (2.0 * vol6);
  const double r2 = dot(rel, rel);
  return squared_distance(p, a + rel) < r2 * (1 - 1e-9);
}

}  // namespace

std::vector<std::vector<std::int32_t>> colour_classes(const WorkMesh& m,
                                                      const std::vector<char>& selected,
                                                      bool two_rings) {
  const std::size_t nv = m.vertex_count();
  std::vector<std::int32_t> colour(nv, -1);
  std::vector<std::vector<std::int32_t>> classes;
  std::vector<char> used;
  std::vector<std::int32_t> ring;
  std::vector<std::int32_t> in_ring(two_rings ? nv : 0, -1);  // v whose ring holds w
  for (std::size_t v = 0; v < nv; ++v) {
    if (!selected[v]) continue;
    used.assign(classes.size() + 1, 0);
    // Repeated neighbours only mark a colour twice; the ring itself (deduplicated with a
    // marker, not a sort: this loop is serial) is needed only for the second ring.
    ring.clear();
    for (std::int32_t t : m.vertex_tets[v])
      for (std::int32_t w : m.tets[t]) {
        if (colour[w] >= 0) used[colour[w]] = 1;
        if (two_rings && in_ring[w] != std::int32_t(v)) in_ring[w] = std::int32_t(v), ring.push_back(w);
      }
    if (two_rings) {
      const bool boundary = m.on_boundary[v] != 0;
      for (std::int32_t w : ring) {
        if (w == std::int32_t(v)) continue;
        for (std::int32_t t : m.vertex_tets[w])
          for (std::int32_t x : m.tets[t])
            if (colour[x] >= 0 && (boundary || m.on_boundary[x])) used[colour[x]] = 1;
      }
    }
    std::int32_t c = 0;
    while (used[c]) ++c;
    colour[v] = c;
    if (std::size_t(c) == classes.size()) classes.emplace_back();
    classes[c].push_back(std::int32_t(v));
  }
  return classes;
}

std::vector<std::int32_t> move_in_classes(WorkMesh& m,
                                          const std::vector<std::vector<std::int32_t>>& classes,
                                          bool mark_failures,
                                          const std::function<Move(std::int32_t, double*)>& move) {
  std::vector<std::int32_t> moved;
  std::vector<Move> moves;
  std::vector<std::size_t> offset;
  std::vector<double> star_quality;
  for (const auto& cls : classes) {
    m.check_cancelled();
    offset.assign(cls.size() + 1, 0);
    for (std::size_t i = 0; i < cls.size(); ++i)
      offset[i + 1] = offset[i] + m.vertex_tets[cls[i]].size();
    star_quality.resize(offset.back());
    moves.assign(cls.size(), Move{});
    tbb::parallel_for(std::size_t(0), cls.size(), [&](std::size_t i) {
      moves[i] = move(cls[i], star_quality.data() + offset[i]);
    });
    for (std::size_t i = 0; i < cls.size(); ++i) {
      const std::int32_t v = cls[i];
      if (!moves[i].moved) {
        if (mark_failures) m.move_failed[v] = m.clock;
        continue;
      }
      m.pos[v] = moves[i].position;
      const auto& star = m.vertex_tets[v];
      for (std::size_t k = 0; k < star.size(); ++k)
        m.quality[star[k]] = star_quality[offset[i] + k];
      m.touch_star(v);
      moved.push_back(v);
    }
  }
  return moved;
}

PassCounts delaunay_flips(WorkMesh& m, const std::vector<std::int32_t>& seeds) {
  PassCounts counts;
  std::vector<std::int32_t> queue = seeds, sharing, ring, ring_tets;
  std::vector<char> queued(m.tets.size(), 0);
  for (std::int32_t t : queue) queued[t] = 1;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const std::int32_t t = queue[head];
    if (std::size_t(t) < queued.size()) queued[t] = 0;
    if (is_dead(m.tets[t])) continue;
    const Tet tet = m.tets[t];
    for (int f = 0; f < 4; ++f) {
      const Triangle face = outward_faces(tet)[f];
      m.tets_with(face.data(), 3, sharing);
      if (sharing.size() != 2) continue;
      const std::int32_t other = sharing[0] == t ? sharing[1] : sharing[0];
      if (m.labels[other] != m.labels[t]) continue;
      std::int32_t e = -1;
      for (std::int32_t v : m.tets[other])
        if (v != face[0] && v != face[1] && v != face[2]) e = v;
      const Vec3 &p0 = m.pos[tet[0]], &p1 = m.pos[tet[1]], &p2 = m.pos[tet[2]], &p3 = m.pos[tet[3]];
      if (!in_circumsphere(p0, p1, p2, p3, m.pos[e])) continue;
      const std::int32_t d = tet[f];
      const double old_min = std::min(m.quality[t], m.quality[other]);
      const double floor = std::min(old_min, 1.0);
      struct {
        enum { none, face_flip, edge_removal } kind = none;
        std::vector<std::int32_t> old_tets;
        std::vector<Tet> new_tets;
        std::vector<double> new_quality;
      } plan;
      // 2-3 flip when de crosses the face.
      if (!m.has_edge(d, e)) {
        const std::array<Tet, 3> nt{Tet{d, e, face[0], face[1]}, Tet{d, e, face[1], face[2]},
                                    Tet{d, e, face[2], face[0]}};
        std::array<double, 3> q{};
        bool ok = true;
        for (int i = 0; i < 3 && ok; ++i) {
          q[i] = m.tet_quality(nt[i]);
          ok = q[i] >= floor && q[i] > kMinValidQuality;
        }
        if (ok) {
          plan.kind = plan.face_flip;
          plan.old_tets = {t, other};
          plan.new_tets.assign(nt.begin(), nt.end());
          plan.new_quality.assign(q.begin(), q.end());
        }
      }
      // Else a 3-2 flip: an edge of the face with exactly three tets around it.
      for (int i = 0; i < 3 && plan.kind == plan.none; ++i) {
        const std::int32_t a = face[i], b = face[(i + 1) % 3];
        if (m.edge_ring(a, b, ring, ring_tets) != WorkMesh::Ring::closed || ring.size() != 3)
          continue;
        if (m.labels[ring_tets[0]] != m.labels[ring_tets[1]] ||
            m.labels[ring_tets[0]] != m.labels[ring_tets[2]])
          continue;
        const Tet ta{a, ring[0], ring[1], ring[2]}, tb{b, ring[0], ring[2], ring[1]};
        const double qa = m.tet_quality(ta), qb = m.tet_quality(tb);
        double ring_min = std::numeric_limits<double>::infinity();
        for (std::int32_t u : ring_tets) ring_min = std::min(ring_min, m.quality[u]);
        const double fl = std::min(ring_min, 1.0);
        if (qa >= fl && qb >= fl && qa > kMinValidQuality && qb > kMinValidQuality) {
          plan.kind = plan.edge_removal;
          plan.old_tets = ring_tets;
          plan.new_tets = {ta, tb};
          plan.new_quality = {qa, qb};
        }
      }
      if (plan.kind == plan.none) continue;
      const std::int32_t label = m.labels[t];
      for (std::int32_t old : plan.old_tets) m.remove_tet(old);
      for (std::size_t i = 0; i < plan.new_tets.size(); ++i) {
        const std::int32_t slot = m.add_tet(plan.new_tets[i], label, plan.new_quality[i]);
        if (std::size_t(slot) >= queued.size()) queued.resize(slot + 1, 0);
        if (!queued[slot]) queued[slot] = 1, queue.push_back(slot);
      }
      ++(plan.kind == plan.face_flip ? counts.face_flips : counts.edge_removals);
      break;  // t is gone
    }
    if (queue.size() > 8 * m.tets.size()) break;  // safety: flips that cycle
    if (head % 4096 == 0) m.check_cancelled();
  }
  return counts;
}

PassCounts odt_smooth(WorkMesh& m, int iterations, bool flips) {
  PassCounts counts;
  std::vector<char> interior(m.vertex_count(), 0);
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    interior[v] = !m.on_boundary[v] && !m.vertex_tets[v].empty();
  for (int it = 0; it < iterations; ++it) {
    const auto classes = colour_classes(m, interior, false);
    const auto moved = move_in_classes(
        m, classes, false, [&](std::int32_t v, double* q) { return odt_move(m, v, q); });
    counts.moved_interior += moved.size();
    if (!flips) continue;
    std::vector<std::int32_t> seeds;
    for (std::size_t t = 0; t < m.tets.size(); ++t)
      if (!is_dead(m.tets[t])) seeds.push_back(std::int32_t(t));
    const PassCounts f = delaunay_flips(m, seeds);
    counts.face_flips += f.face_flips;
    counts.edge_removals += f.edge_removals;
  }
  return counts;
}

}  // namespace cvt::opt
