// Stage 6, geometric part: vertex moves that raise the smallest quality of a vertex's star, in
// the spirit of Freitag & Ollivier-Gooch's non-smooth optimisation-based smoothing (as used by
// Klingner & Shewchuk) and of CGAL Mesh_3's sliver perturber (move a sliver's vertex along the
// gradient of its quality). The ascent direction is the smallest vector in the convex hull of
// the gradients of the worst incident tets (it raises them all); the step is the first point
// where the linearised quality of another tet would catch up, halved until the star's minimum
// really rises. Boundary vertices move in the tangent plane of the level set and are projected
// back onto it, so they stay on the segmentation's sub-voxel surface.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "mesh_optimization_work.h"

namespace cvt::opt {
namespace {

constexpr double kMinValidQuality = 1e-6;
constexpr int kMaxActive = 6;
constexpr double kActiveBand = 1e-3;  // tets within this of the star's minimum are active

// Quality of star tet `t` with vertex v at x.
double quality_at(const WorkMesh& m, std::int32_t t, std::int32_t v, const Vec3& x,
                  double floor = -std::numeric_limits<double>::infinity()) {
  const Tet& tet = m.tets[t];
  const Vec3* p[4];
  for (int i = 0; i < 4; ++i) p[i] = tet[i] == v ? &x : &m.pos[tet[i]];
  return m.tet_quality(*p[0], *p[1], *p[2], *p[3], floor);
}

// The smallest vector in the convex hull of g[0..n) (Frank–Wolfe with exact line search).
Vec3 min_norm_in_hull(const Vec3* g, int n) {
  Vec3 p = g[0];
  for (int it = 0; it < 64; ++it) {
    int best = 0;
    double lowest = std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) {
      const double d = dot(p, g[i]);
      if (d < lowest) lowest = d, best = i;
    }
    const double pp = dot(p, p);
    if (pp - lowest <= 1e-12 * pp) break;
    const Vec3 e = g[best] - p;
    const double ee = dot(e, e);
    if (ee <= 0) break;
    const double s = std::clamp(-dot(p, e) / ee, 0.0, 1.0);
    p += e * s;
  }
  return p;
}

// A vertex move (the star's qualities at the new position are written apart).
struct Move {
  Vec3 position;
  bool moved = false;
};

// Best position found for vertex v (its neighbours fixed); when it moves, the star's
// qualities there go to star_quality (in vertex_tets order).
Move optimise_vertex(const WorkMesh& m, std::int32_t v, const LevelSetSurface* surface,
                     const SmoothingOptions& o, double* star_quality) {
  const std::vector<std::int32_t>& star = m.vertex_tets[v];
  const std::size_t n = star.size();
  const bool slide = m.on_boundary[v] != 0;
  std::vector<double> q(n), trial(n);
  std::vector<Vec3> grads(n);
  std::vector<char> has_grad(n);
  for (std::size_t i = 0; i < n; ++i) q[i] = m.quality[star[i]];
  double shortest = std::numeric_limits<double>::infinity();
  for (std::int32_t t : star)
    for (std::int32_t w : m.tets[t])
      if (w != v) shortest = std::min(shortest, distance(m.pos[w], m.pos[v]));
  const double max_step = o.max_step_fraction * shortest;
  const double h = 1e-6 * shortest;
  Vec3 x = m.pos[v];
  bool moved = false;
  for (int iteration = 0; iteration < o.iterations; ++iteration) {
    const double qmin = *std::min_element(q.begin(), q.end());
    Vec3 normal{0, 0, 0};
    if (slide) normal = surface->unit_normal(x);
    // Gradients of the active (worst) tets.
    Vec3 g[kMaxActive];
    int active = 0;
    std::fill(has_grad.begin(), has_grad.end(), 0);
    auto gradient = [&](std::size_t i) {
      Vec3 gi;
      for (int a = 0; a < 3; ++a) {
        Vec3 lo = x, hi = x;
        lo[a] -= h;
        hi[a] += h;
        gi[a] = (quality_at(m, star[i], v, hi) - quality_at(m, star[i], v, lo)) / (2 * h);
      }
      if (slide) gi -= normal * dot(gi, normal);
      return gi;
    };
    for (std::size_t i = 0; i < n && active < kMaxActive; ++i)
      if (q[i] <= qmin + kActiveBand) {
        grads[i] = gradient(i);
        has_grad[i] = 1;
        g[active++] = grads[i];
      }
    const Vec3 d = min_norm_in_hull(g, active);
    const double dd = dot(d, d);
    if (!(dd > 0) || !std::isfinite(dd)) break;
    // Rate at which the active tets rise along d (≥ |d|² at the min-norm point).
    double rate = std::numeric_limits<double>::infinity();
    for (int i = 0; i < active; ++i) rate = std::min(rate, dot(g[i], d));
    if (!(rate > 0)) break;
    // First step length where an inactive tet's linearised quality meets the active ones.
    double alpha = max_step / std::sqrt(dd);
    for (std::size_t i = 0; i < n; ++i) {
      if (has_grad[i]) continue;
      const double gap = q[i] - qmin;
      if (gap > alpha * rate) continue;  // cannot meet within the step
      const Vec3 gi = gradient(i);
      const double closing = rate - dot(gi, d);
      if (closing > 0) alpha = std::min(alpha, gap / closing);
    }
    bool accepted = false;
    for (int attempt = 0; attempt < 6 && !accepted; ++attempt, alpha *= 0.5) {
      Vec3 y = x + d * alpha;
      if (slide && !surface->project(y, max_step)) continue;
      double new_min = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < n && new_min > qmin; ++i) {
        trial[i] = quality_at(m, star[i], v, y, qmin);
        new_min = std::min(new_min, trial[i]);
      }
      if (new_min > qmin + 1e-9 && new_min > kMinValidQuality) {
        x = y;
        q.swap(trial);
        accepted = moved = true;
      }
    }
    if (!accepted) break;
  }
  if (moved) std::copy(q.begin(), q.end(), star_quality);
  return {x, moved};
}

// Greedy colouring in index order of the selected vertices: no two of one class share a tet.
std::vector<std::vector<std::int32_t>> colour_classes(const WorkMesh& m,
                                                      const std::vector<char>& selected) {
  const std::size_t nv = m.vertex_count();
  std::vector<std::int32_t> colour(nv, -1);
  std::vector<std::vector<std::int32_t>> classes;
  std::vector<char> used;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!selected[v]) continue;
    used.assign(classes.size() + 1, 0);
    for (std::int32_t t : m.vertex_tets[v])
      for (std::int32_t w : m.tets[t])
        if (colour[w] >= 0) used[colour[w]] = 1;
    std::int32_t c = 0;
    while (used[c]) ++c;
    colour[v] = c;
    if (std::size_t(c) == classes.size()) classes.emplace_back();
    classes[c].push_back(std::int32_t(v));
  }
  return classes;
}

// Runs move(v, star_quality_out) for every vertex of each colour class in parallel (their
// stars share no tet, so the moves are independent), then applies the moves in order.
// Returns the vertices moved; with mark_failures, those not moved are marked as failed.
template <class MoveFn>
std::vector<std::int32_t> move_in_classes(WorkMesh& m,
                                          const std::vector<std::vector<std::int32_t>>& classes,
                                          bool mark_failures, MoveFn&& move) {
  std::vector<std::int32_t> moved;
  std::vector<Move> moves;
  std::vector<std::size_t> offset;
  std::vector<double> star_quality;
  for (const auto& cls : classes) {
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

}  // namespace

PassCounts smooth_vertices(WorkMesh& m, const LevelSetSurface* surface, const SmoothingOptions& o) {
  PassCounts counts;
  // Vertices of bad tets that may move, unless nothing changed since their last failure.
  std::vector<char> candidate(m.vertex_count(), 0);
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    if (is_dead(m.tets[t]) || m.quality[t] >= o.bad_below) continue;
    for (std::int32_t v : m.tets[t]) {
      const bool may_move =
          m.on_boundary[v] ? o.move_surface && surface && !m.on_surface.empty() && m.on_surface[v]
                           : o.move_interior;
      if (may_move && m.vertex_stamp[v] > m.move_failed[v]) candidate[v] = 1;
    }
  }
  const auto moved = move_in_classes(
      m, colour_classes(m, candidate), true,
      [&](std::int32_t v, double* q) { return optimise_vertex(m, v, surface, o, q); });
  for (std::int32_t v : moved) ++(m.on_boundary[v] ? counts.moved_surface : counts.moved_interior);
  return counts;
}

PassCounts odt_smooth(WorkMesh& m, int iterations, bool flips) {
  PassCounts counts;
  std::vector<char> interior(m.vertex_count(), 0);
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    interior[v] = !m.on_boundary[v] && !m.vertex_tets[v].empty();
  for (int it = 0; it < iterations; ++it) {
    const auto classes = colour_classes(m, interior);
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
