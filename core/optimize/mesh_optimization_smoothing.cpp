// Stage 6, geometric part: vertex moves that raise the smallest quality of a vertex's star, in
// the spirit of Freitag & Ollivier-Gooch's non-smooth optimisation-based smoothing (as used by
// Klingner & Shewchuk) and of CGAL Mesh_3's sliver perturber (move a sliver's vertex along the
// gradient of its quality). The ascent direction is the smallest vector in the convex hull of
// the gradients of the worst incident tets (it raises them all); the step is the first point
// where the linearised quality of another tet would catch up, halved until the star's minimum
// really rises. Boundary vertices move in the tangent plane of the level set and are projected
// back onto it, so they stay on the segmentation's sub-voxel surface.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "optimize/mesh_optimization_work.h"

namespace cvt::opt {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxActive = 6;
constexpr double kActiveBand = 1e-3;  // tets within this of the star's minimum are active

// Whether the interiors of two tets intersect (separating axis test: face normals and edge
// cross products; touching along shared vertices, edges or faces is no overlap). `scale2` is a
// squared length of the neighbourhood, for the tolerance.
bool tets_overlap(const std::array<Vec3, 4>& a, const std::array<Vec3, 4>& b, double scale2) {
  static constexpr int kE[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  static constexpr int kF[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  auto separated = [&](const Vec3& axis) {
    const double len2 = dot(axis, axis);
    if (!(len2 > 1e-24 * scale2 * scale2)) return false;  // degenerate axis
    double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
    for (int i = 0; i < 4; ++i) {
      const double pa = dot(axis, a[i]), pb = dot(axis, b[i]);
      amin = std::min(amin, pa), amax = std::max(amax, pa);
      bmin = std::min(bmin, pb), bmax = std::max(bmax, pb);
    }
    const double eps = 1e-9 * std::sqrt(len2 * scale2);
    return amax <= bmin + eps || bmax <= amin + eps;
  };
  for (const auto& f : kF) {
    if (separated(cross(a[f[1]] - a[f[0]], a[f[2]] - a[f[0]]))) return false;
    if (separated(cross(b[f[1]] - b[f[0]], b[f[2]] - b[f[0]]))) return false;
  }
  for (const auto& ea : kE)
    for (const auto& eb : kE)
      if (separated(cross(a[ea[1]] - a[ea[0]], b[eb[1]] - b[eb[0]]))) return false;
  return true;
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

// What keeps a boundary vertex's star embedded when the vertex moves. Its star is not closed:
// every tet staying positive does not keep it from sliding over a neighbour's boundary
// triangles (folding the boundary onto other tets). So its boundary triangles (the other two
// vertices, outward order) must keep facing the way they did, the star must not overlap itself,
// and it must not swallow or enter the tets around it.
class BoundaryStar {
 public:
  BoundaryStar(const WorkMesh& m, std::int32_t v, double shortest_edge)
      : m_(m), v_(v), star_(m.vertex_tets[v]), shortest_(shortest_edge) {
    const Vec3& x = m.pos[v];
    std::vector<std::array<std::int32_t, 2>> faces;  // faces through v: the other two, in order
    for (std::int32_t t : star_)
      for (const Triangle& f : outward_faces(m.tets[t])) {
        int at = -1;
        for (int i = 0; i < 3; ++i)
          if (f[i] == v) at = i;
        if (at < 0) continue;
        faces.push_back({f[(at + 1) % 3], f[(at + 2) % 3]});
      }
    for (std::size_t i = 0; i < faces.size(); ++i) {
      bool shared = false;  // an interior face appears twice, with its two vertices swapped
      for (std::size_t j = 0; j < faces.size() && !shared; ++j)
        shared = j != i && faces[j][0] == faces[i][1] && faces[j][1] == faces[i][0];
      if (!shared) boundary_edges_.push_back(faces[i]);
    }
    for (const auto& e : boundary_edges_)
      start_normal_.push_back(cross(m.pos[e[0]] - x, m.pos[e[1]] - x));
    for (const Vec3& n : start_normal_) axis_ += n;
    axis_ = axis_ / norm(axis_);
  }

  // Each boundary triangle turns by less than 60° from where it started.
  bool faces_turn_little(const Vec3& y) const {
    for (std::size_t i = 0; i < boundary_edges_.size(); ++i) {
      const Vec3 n = cross(m_.pos[boundary_edges_[i][0]] - y, m_.pos[boundary_edges_[i][1]] - y);
      if (!(dot(n, start_normal_[i]) > 0.5 * norm(n) * norm(start_normal_[i]))) return false;
    }
    return true;
  }

  // Whether, seen from y, the star's boundary cycle goes once around the boundary normal (as it
  // started), each step forward: then the star's central projection from y is one-to-one, so
  // (its tets being positive) the star does not overlap itself.
  bool projects_one_to_one(const Vec3& y) const {
    double turn = 0;  // azimuth swept around the axis
    for (const auto& e : boundary_edges_) {
      const Vec3 a = m_.pos[e[0]] - y, b = m_.pos[e[1]] - y;
      const Vec3 ap = a - axis_ * dot(a, axis_), bp = b - axis_ * dot(b, axis_);
      const double step = std::atan2(dot(axis_, cross(ap, bp)), dot(ap, bp));
      if (!(step > 0)) return false;
      turn += step;
    }
    return std::abs(turn - 2 * kPi) < 1e-6;
  }

  // No two tets of the star overlap with v at y (costly: tet against tet).
  bool unfolded(const Vec3& y) const {
    const std::size_t k = star_.size();
    std::vector<std::array<Vec3, 4>> c(k);
    std::vector<std::array<Vec3, 2>> box(k);
    for (std::size_t i = 0; i < k; ++i) {
      box[i] = {y, y};
      for (int j = 0; j < 4; ++j) {
        c[i][j] = m_.tets[star_[i]][j] == v_ ? y : m_.pos[m_.tets[star_[i]][j]];
        for (int a = 0; a < 3; ++a)
          box[i][0][a] = std::min(box[i][0][a], c[i][j][a]),
          box[i][1][a] = std::max(box[i][1][a], c[i][j][a]);
      }
    }
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = i + 1; j < k; ++j) {
        // Two positive tets sharing a face lie on its two sides; boxes apart cannot overlap.
        int shared = 0;
        for (std::int32_t a : m_.tets[star_[i]])
          for (std::int32_t b : m_.tets[star_[j]]) shared += a == b;
        if (shared == 3) continue;
        bool apart = false;
        for (int a = 0; a < 3 && !apart; ++a)
          apart = box[i][1][a] <= box[j][0][a] || box[j][1][a] <= box[i][0][a];
        if (!apart && tets_overlap(c[i], c[j], shortest_ * shortest_)) return false;
      }
    return true;
  }

  // With v at y, v lies in none of the tets around its neighbours and the star swallows none
  // of the vertices they reach (link vertices included: a neighbour can end up inside a star
  // tet it is not a vertex of; a tet's own vertices are on its boundary, never strictly inside).
  bool stays_embedded(const Vec3& y) {
    if (!gathered_) gather();
    // Bounding box of the moved star: only vertices in it can be swallowed.
    Vec3 lo = y, hi = y;
    for (std::int32_t t : star_)
      for (std::int32_t w : m_.tets[t])
        for (int c = 0; c < 3; ++c)
          lo[c] = std::min(lo[c], m_.pos[w][c]), hi[c] = std::max(hi[c], m_.pos[w][c]);
    auto in_box = [&](const Vec3& p) {
      return p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y && p.z > lo.z && p.z < hi.z;
    };
    for (std::int32_t t : near_tets_) {
      const Tet& tet = m_.tets[t];
      const Vec3* c[4] = {&m_.pos[tet[0]], &m_.pos[tet[1]], &m_.pos[tet[2]], &m_.pos[tet[3]]};
      bool outside_box = false;  // y outside the tet's box: not inside it
      for (int a = 0; a < 3 && !outside_box; ++a)
        outside_box =
            (y[a] < (*c[0])[a] && y[a] < (*c[1])[a] && y[a] < (*c[2])[a] && y[a] < (*c[3])[a]) ||
            (y[a] > (*c[0])[a] && y[a] > (*c[1])[a] && y[a] > (*c[2])[a] && y[a] > (*c[3])[a]);
      if (!outside_box && inside(y, c)) return false;
    }
    for (std::int32_t u : near_vertices_) {
      if (u == v_ || !in_box(m_.pos[u])) continue;
      for (std::int32_t t : star_) {
        const Tet& tet = m_.tets[t];
        const Vec3* c[4];
        for (int i = 0; i < 4; ++i) c[i] = tet[i] == v_ ? &y : &m_.pos[tet[i]];
        if (inside(m_.pos[u], c)) return false;
      }
    }
    return true;
  }

 private:
  static bool inside(const Vec3& p, const Vec3* c[4]) {
    const Tet order{0, 1, 2, 3};
    for (const Triangle& f : outward_faces(order)) {
      const Vec3 &a = *c[f[0]], &b = *c[f[1]], &d = *c[f[2]];
      if (dot(b - a, cross(d - a, p - a)) >= 0) return false;
    }
    return true;
  }

  // The tets around the neighbours (not v's) and the vertices they reach.
  void gather() {
    gathered_ = true;
    // Epoch marks instead of sorting (this runs for every boundary vertex that moves).
    thread_local std::vector<std::uint32_t> tet_mark, vertex_mark;
    thread_local std::uint32_t epoch = 0;
    if (tet_mark.size() < m_.tets.size()) tet_mark.resize(m_.tets.size() + 1024, 0);
    if (vertex_mark.size() < m_.vertex_count()) vertex_mark.resize(m_.vertex_count() + 1024, 0);
    if (++epoch == 0) {  // wrapped: start afresh
      std::fill(tet_mark.begin(), tet_mark.end(), 0);
      std::fill(vertex_mark.begin(), vertex_mark.end(), 0);
      epoch = 1;
    }
    std::vector<std::int32_t> link;
    vertex_mark[v_] = epoch;
    for (std::int32_t t : star_) {
      tet_mark[t] = epoch;
      for (std::int32_t w : m_.tets[t])
        if (vertex_mark[w] != epoch) vertex_mark[w] = epoch, link.push_back(w);
    }
    near_vertices_ = link;
    for (std::int32_t w : link)
      for (std::int32_t t : m_.vertex_tets[w]) {
        if (tet_mark[t] == epoch) continue;
        tet_mark[t] = epoch;
        near_tets_.push_back(t);
        for (std::int32_t u : m_.tets[t])
          if (vertex_mark[u] != epoch) vertex_mark[u] = epoch, near_vertices_.push_back(u);
      }
  }

  const WorkMesh& m_;
  std::int32_t v_;
  const std::vector<std::int32_t>& star_;
  double shortest_;
  std::vector<std::array<std::int32_t, 2>> boundary_edges_;  // (x, y): triangle (v, x, y)
  std::vector<Vec3> start_normal_;
  Vec3 axis_{0, 0, 0};  // the boundary normal at v (area-weighted, as it started)
  bool gathered_ = false;
  std::vector<std::int32_t> near_tets_, near_vertices_;
};

double shortest_star_edge(const WorkMesh& m, std::int32_t v) {
  double shortest = std::numeric_limits<double>::infinity();
  for (std::int32_t t : m.vertex_tets[v])
    for (std::int32_t w : m.tets[t])
      if (w != v) shortest = std::min(shortest, distance(m.pos[w], m.pos[v]));
  return shortest;
}

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
  const double shortest = shortest_star_edge(m, v);
  const double max_step = o.max_step_fraction * shortest;
  const double h = 1e-6 * shortest;
  Vec3 x = m.pos[v];
  bool moved = false;
  std::optional<BoundaryStar> boundary;
  if (slide) boundary.emplace(m, v, shortest);
  std::vector<std::pair<Vec3, std::vector<double>>> steps;  // accepted positions (sliding)
  // Where the test fails even as the star is (its boundary cycle is not monotone around the
  // normal: a curved, uneven neighbourhood), the moved star is checked tet against tet.
  const bool monotone = !slide || boundary->projects_one_to_one(x);
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
      if (slide && (!surface->project(y, max_step) || !boundary->faces_turn_little(y) ||
                    (monotone && !boundary->projects_one_to_one(y))))
        continue;
      double new_min = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < n && new_min > qmin; ++i) {
        trial[i] = quality_at(m, star[i], v, y, qmin);
        new_min = std::min(new_min, trial[i]);
      }
      if (new_min > qmin + 1e-9 && new_min > kMinValidQuality) {
        x = y;
        q.swap(trial);
        accepted = moved = true;
        if (slide) steps.push_back({x, q});
      }
    }
    if (!accepted) break;
  }
  if (slide && moved) {
    // The embedding check is costly: made on the end position, else on earlier ones.
    while (!steps.empty() &&
           !((monotone || boundary->unfolded(steps.back().first)) &&
             boundary->stays_embedded(steps.back().first)))
      steps.pop_back();
    if (steps.empty()) return {m.pos[v], false};
    x = steps.back().first;
    q = steps.back().second;
  }
  if (moved) std::copy(q.begin(), q.end(), star_quality);
  return {x, moved};
}

}  // namespace

Move move_boundary_vertex(const WorkMesh& m, std::int32_t v, const Vec3& target,
                          double bad_below, double* star_quality) {
  const std::vector<std::int32_t>& star = m.vertex_tets[v];
  const std::size_t n = star.size();
  double qmin = std::numeric_limits<double>::infinity();
  for (std::int32_t t : star) qmin = std::min(qmin, m.quality[t]);
  const double floor = std::max(std::min(qmin, bad_below), kMinValidQuality);
  const Vec3 x = m.pos[v];
  BoundaryStar boundary(m, v, shortest_star_edge(m, v));
  const bool monotone = boundary.projects_one_to_one(x);
  std::vector<double> trial(n);
  for (const double fraction : {1.0, 0.5, 0.25}) {
    const Vec3 y = x + (target - x) * fraction;
    if (!boundary.faces_turn_little(y) || (monotone && !boundary.projects_one_to_one(y)))
      continue;
    bool good = true;
    for (std::size_t i = 0; i < n && good; ++i) {
      trial[i] = quality_at(m, star[i], v, y);
      good = trial[i] >= floor;
    }
    if (!good || !(monotone || boundary.unfolded(y)) || !boundary.stays_embedded(y)) continue;
    std::copy(trial.begin(), trial.end(), star_quality);
    return {y, true};
  }
  return {x, false};
}

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
      m, colour_classes(m, candidate, true), true,
      [&](std::int32_t v, double* q) { return optimise_vertex(m, v, surface, o, q); });
  for (std::int32_t v : moved) ++(m.on_boundary[v] ? counts.moved_surface : counts.moved_interior);
  return counts;
}


PassCounts snap_to_surface(WorkMesh& m, const LevelSetSurface& surface, double tolerance_mm,
                           double bad_below) {
  PassCounts counts;
  if (m.on_surface.empty()) return counts;
  std::vector<char> candidate(m.vertex_count(), 0);
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    candidate[v] = m.on_boundary[v] && !m.on_surface[v] && !m.vertex_tets[v].empty() &&
                   m.vertex_stamp[v] > m.move_failed[v];
  const auto moved = move_in_classes(
      m, colour_classes(m, candidate, true), true, [&](std::int32_t v, double* q) {
        Vec3 target = m.pos[v];
        if (!surface.project(target, 20.0 * surface.min_spacing_mm())) return Move{m.pos[v]};
        return move_boundary_vertex(m, v, target, bad_below, q);
      });
  for (std::int32_t v : moved)
    if (surface.distance(m.pos[v]) <= tolerance_mm) {
      m.on_surface[v] = 1;
      ++counts.snapped_surface;
    } else {
      ++counts.moved_surface;
    }
  return counts;
}

}  // namespace cvt::opt
