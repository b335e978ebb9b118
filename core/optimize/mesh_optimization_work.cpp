#include "optimize/mesh_optimization_work.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "evaluate/quality.h"
#include "fields/smoothing.h"
#include "sampling/surface_sampling.h"

namespace cvt::opt {

double min_sine(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 ab = b - a, ac = c - a, ad = d - a, bc = c - b, bd = d - b, cd = d - c;
  const Vec3 nd = cross(ab, ac);  // face abc (opposite d), twice its area in length
  const double vol6 = dot(nd, ad);
  if (!(vol6 > 0)) return -1.0;
  // Twice the area of the face opposite each vertex.
  const double Aa = norm(cross(bc, bd)), Ab = norm(cross(ac, ad)), Ac = norm(cross(ab, ad)),
               Ad = norm(nd);
  // sin θ_e = 3 V ℓ_e / (2 A_i A_j) with the two faces through edge e; with doubled areas
  // and 6V this is 6V ℓ_e / (2A_i · 2A_j).
  const double s = std::min({norm(ab) / (Ac * Ad), norm(ac) / (Ab * Ad), norm(ad) / (Ab * Ac),
                             norm(bc) / (Aa * Ad), norm(bd) / (Aa * Ac), norm(cd) / (Aa * Ab)});
  const double q = vol6 * s;
  return std::isfinite(q) ? q : -1.0;
}

double tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                   const QualityScale& scale, double floor) {
  const Vec3 p[4] = {a, b, c, d};
  const Vec3 ab = b - a, ac = c - a, ad = d - a, bc = c - b, bd = d - b;
  const Vec3 nd = cross(ab, ac);
  const double vol6 = dot(nd, ad);
  if (!(vol6 > 0)) return -1.0;
  // Cheapest figures first, so a tet known to be no better than `floor` is left early.
  // Twice the area of the face opposite each vertex.
  const Vec3 na = cross(bc, bd), nb = cross(ac, ad), nc = cross(ab, ad);
  const double S2[4] = {dot(na, na), dot(nb, nb), dot(nc, nc), dot(nd, nd)};  // (2A)²
  const double V = vol6 / 6.0;
  const auto pow34 = [](double x) { return std::sqrt(x * std::sqrt(x)); };
  // Condition number measure V / ((1/4) Σ A²)^{3/4}.
  double q = V / pow34(0.0625 * (S2[0] + S2[1] + S2[2] + S2[3])) / scale.condition_number;
  if (!(q > floor)) return std::isfinite(q) ? q : -1.0;
  const double A2[4] = {std::sqrt(S2[0]), std::sqrt(S2[1]), std::sqrt(S2[2]), std::sqrt(S2[3])};
  // Edges (i, j) with the faces through them (opposite k and l).
  static constexpr int kE[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                   {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  double l2[6], sine = std::numeric_limits<double>::infinity(), cross_sum = 0;
  for (int e = 0; e < 6; ++e) {
    l2[e] = squared_distance(p[kE[e][0]], p[kE[e][1]]);
    // sin θ_e = 3 V ℓ_e / (2 A_k A_l) = 6V ℓ_e / ((2A_k)(2A_l)); compared squared.
    sine = std::min(sine, l2[e] / (S2[kE[e][2]] * S2[kE[e][3]]));
    cross_sum += A2[kE[e][0]] * A2[kE[e][1]] * l2[e];  // (2A_i)(2A_j) ℓ²
  }
  q = std::min(q, vol6 * std::sqrt(sine) / scale.sine);
  if (!(q > floor)) return std::isfinite(q) ? q : -1.0;
  const double sum_a = 0.5 * (A2[0] + A2[1] + A2[2] + A2[3]);
  q = std::min(q, V * pow34(sum_a / (0.25 * cross_sum)) / scale.gradient_error);
  if (!(q > floor)) return std::isfinite(q) ? q : -1.0;
  // V / r_mc³ last, and the smallest enclosing ball only when needed: r_mc is the circumradius
  // R when the circumcentre is inside the tet, else smaller, so V / R³ is a lower bound.
  const Vec3 rel = (nb * dot(ab, ab) - nc * dot(ac, ac) + nd * dot(ad, ad)) / (2.0 * vol6);
  const double R = norm(rel);
  const double lower = V / (R * R * R) / scale.v_over_rmc3;
  if (!(lower >= q)) {
    // The circumcentre is inside when on the inner side of every face (outward normals of a
    // positive tet: faces opposite a, b, c, d).
    const Vec3 o = a + rel;
    const bool inside =
        dot(o - b, na) <= 0 && dot(o - a, nb) >= 0 && dot(o - a, nc) <= 0 && dot(o - a, nd) >= 0;
    double rmc = R;
    if (!inside) {
      // Often the diametral ball of the longest edge contains the tet (then it is the
      // smallest, as r_mc ≥ half the longest edge); else the general search.
      int longest = 0;
      for (int e = 1; e < 6; ++e)
        if (l2[e] > l2[longest]) longest = e;
      const Vec3 mid = (p[kE[longest][0]] + p[kE[longest][1]]) * 0.5;
      const double r2 = 0.25 * l2[longest] * (1 + 1e-12);
      if (squared_distance(p[kE[longest][2]], mid) <= r2 &&
          squared_distance(p[kE[longest][3]], mid) <= r2)
        rmc = 0.5 * std::sqrt(l2[longest]);
      else
        rmc = min_containing_ball_radius(a, b, c, d);
    }
    q = std::min(q, V / (rmc * rmc * rmc) / scale.v_over_rmc3);
  }
  return std::isfinite(q) ? q : -1.0;
}

WorkMesh::WorkMesh(const TetMesh& mesh, const QualityScale& quality_scale)
    : pos(mesh.vertices),
      tets(mesh.tets),
      vertex_tets(mesh.vertices.size()),
      on_boundary(mesh.vertices.size(), 0) {
  scale = quality_scale;
  labels = mesh.labels.empty() ? std::vector<std::int32_t>(tets.size(), 1) : mesh.labels;
  quality.resize(tets.size());
  std::vector<std::int32_t> degree(pos.size(), 0);
  for (const Tet& t : tets)
    for (std::int32_t v : t) ++degree[v];
  for (std::size_t v = 0; v < pos.size(); ++v) vertex_tets[v].reserve(degree[v] + 4);
  tbb::parallel_for(std::size_t(0), tets.size(),
                    [&](std::size_t t) { quality[t] = tet_quality(tets[t]); });
  for (std::size_t t = 0; t < tets.size(); ++t)
    for (std::int32_t v : tets[t]) vertex_tets[v].push_back(std::int32_t(t));
  for (const Triangle& f : boundary_triangles(mesh))
    for (std::int32_t v : f) on_boundary[v] = 1;
  vertex_stamp.assign(pos.size(), clock);
  flip_failed.assign(tets.size(), 0);
  insert_failed.assign(tets.size(), 0);
  move_failed.assign(pos.size(), 0);
}

TetMesh WorkMesh::to_mesh(std::vector<std::int32_t>* origin) const {
  TetMesh m;
  std::vector<std::int32_t> index(pos.size(), -1);
  if (origin) origin->clear();
  for (std::size_t v = 0; v < pos.size(); ++v) {
    if (vertex_tets[v].empty()) continue;
    index[v] = std::int32_t(m.vertices.size());
    m.vertices.push_back(pos[v]);
    if (origin) origin->push_back(std::int32_t(v));
  }
  m.tets.reserve(live_tets());
  bool all_one = true;
  for (std::size_t t = 0; t < tets.size(); ++t) {
    if (is_dead(tets[t])) continue;
    const Tet& s = tets[t];
    m.tets.push_back({index[s[0]], index[s[1]], index[s[2]], index[s[3]]});
    m.labels.push_back(labels[t]);
    all_one = all_one && labels[t] == 1;
  }
  if (all_one) m.labels.clear();
  return m;
}

std::int32_t WorkMesh::add_tet(const Tet& t, std::int32_t label, double q) {
  std::int32_t slot;
  if (!free_slots.empty()) {
    slot = free_slots.back();
    free_slots.pop_back();
    tets[slot] = t;
    labels[slot] = label;
    quality[slot] = q;
    flip_failed[slot] = 0;
    insert_failed[slot] = 0;
  } else {
    slot = std::int32_t(tets.size());
    tets.push_back(t);
    labels.push_back(label);
    quality.push_back(q);
    flip_failed.push_back(0);
    insert_failed.push_back(0);
  }
  ++clock;
  for (std::int32_t v : t) vertex_tets[v].push_back(slot), vertex_stamp[v] = clock;
  return slot;
}

void WorkMesh::remove_tet(std::int32_t slot) {
  ++clock;
  for (std::int32_t v : tets[slot]) {
    vertex_stamp[v] = clock;
    auto& list = vertex_tets[v];
    list.erase(std::find(list.begin(), list.end(), slot));  // keeps the order: deterministic
  }
  tets[slot] = {-1, -1, -1, -1};
  free_slots.push_back(slot);
}

void WorkMesh::tets_with(const std::int32_t* vs, int count, std::vector<std::int32_t>& out) const {
  out.clear();
  for (std::int32_t t : vertex_tets[vs[0]]) {
    const Tet& tet = tets[t];
    bool all = true;
    for (int i = 1; i < count && all; ++i)
      all = tet[0] == vs[i] || tet[1] == vs[i] || tet[2] == vs[i] || tet[3] == vs[i];
    if (all) out.push_back(t);
  }
}

Tet rotate_to_edge(const Tet& t, std::int32_t a, std::int32_t b) {
  int ia = 0, ib = 0;
  for (int i = 0; i < 4; ++i) {
    if (t[i] == a) ia = i;
    if (t[i] == b) ib = i;
  }
  int rest[2], n = 0;
  for (int i = 0; i < 4; ++i)
    if (i != ia && i != ib) rest[n++] = i;
  const int p[4] = {ia, ib, rest[0], rest[1]};
  int inversions = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) inversions += p[i] > p[j];
  return inversions % 2 == 0 ? Tet{a, b, t[rest[0]], t[rest[1]]}
                             : Tet{a, b, t[rest[1]], t[rest[0]]};
}

WorkMesh::Ring WorkMesh::edge_ring(std::int32_t a, std::int32_t b, std::vector<std::int32_t>& ring,
                                   std::vector<std::int32_t>& ring_tets) const {
  ring.clear();
  ring_tets.clear();
  // Link edges c → d of each tet (a, b, c, d) around the edge (fixed buffers: this is hot).
  constexpr int kMax = 64;
  std::int32_t around[kMax], from[kMax], to[kMax];
  int n = 0;
  for (std::int32_t t : vertex_tets[a]) {
    const Tet& tet = tets[t];
    if (tet[0] != b && tet[1] != b && tet[2] != b && tet[3] != b) continue;
    if (n == kMax) return Ring::none;
    const Tet r = rotate_to_edge(tet, a, b);
    around[n] = t;
    from[n] = r[2];
    to[n] = r[3];
    ++n;
  }
  if (n == 0) return Ring::none;
  // Start where no link edge ends (an open fan), else at the first tet.
  int start = 0;
  bool open = false;
  for (int i = 0; i < n && !open; ++i) {
    open = std::find(to, to + n, from[i]) == to + n;
    if (open) start = i;
  }
  int at = start;
  for (int k = 0; k < n; ++k) {
    ring.push_back(from[at]);
    ring_tets.push_back(around[at]);
    int next = -1;
    for (int j = 0; j < n; ++j)
      if (from[j] == to[at]) {
        if (next >= 0) return Ring::none;  // two tets continue from one vertex
        next = j;
      }
    if (next < 0) {  // the fan ends
      if (!open || k + 1 != n) return Ring::none;
      ring.push_back(to[at]);
      return Ring::open;
    }
    at = next;
    if (at == start && k + 1 != n) return Ring::none;  // closed early: several cycles
  }
  return !open && at == start ? Ring::closed : Ring::none;
}

std::vector<Triangle> boundary_faces(const WorkMesh& m) {
  std::vector<std::array<Triangle, 4>> per_tet(m.tets.size());
  std::vector<std::uint8_t> count(m.tets.size(), 0);
  tbb::parallel_for(std::size_t(0), m.tets.size(), [&](std::size_t t) {
    const Tet& tet = m.tets[t];
    if (is_dead(tet)) return;
    for (const Triangle& f : outward_faces(tet)) {
      if (!m.on_boundary[f[0]] || !m.on_boundary[f[1]] || !m.on_boundary[f[2]]) continue;
      bool shared = false;
      for (std::int32_t u : m.vertex_tets[f[0]]) {
        if (u == std::int32_t(t)) continue;
        const Tet& o = m.tets[u];
        auto has = [&](std::int32_t w) { return o[0] == w || o[1] == w || o[2] == w || o[3] == w; };
        if (has(f[1]) && has(f[2])) {
          shared = true;
          break;
        }
      }
      if (!shared) per_tet[t][count[t]++] = f;
    }
  });
  std::vector<Triangle> faces;
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    for (int k = 0; k < count[t]; ++k) faces.push_back(per_tet[t][k]);
  return faces;
}

bool WorkMesh::has_edge(std::int32_t a, std::int32_t b) const {
  for (std::int32_t t : vertex_tets[a]) {
    const Tet& tet = tets[t];
    if (tet[0] == b || tet[1] == b || tet[2] == b || tet[3] == b) return true;
  }
  return false;
}

bool WorkMesh::is_boundary_edge(std::int32_t a, std::int32_t b) const {
  if (!on_boundary[a] || !on_boundary[b]) return false;
  thread_local std::vector<std::int32_t> ring, ring_tets;
  return edge_ring(a, b, ring, ring_tets) == Ring::open;
}

namespace {

// The field's gradient in the world frame (per mm).
template <class T>
Vec3 world_gradient(const Volume<T>& field, const Vec3& index) {
  const Vec3 g = gradient_local(field, index);
  const auto& d = field.grid.direction;  // row-major, columns = axes
  return {d[0] * g.x + d[1] * g.y + d[2] * g.z, d[3] * g.x + d[4] * g.y + d[5] * g.z,
          d[6] * g.x + d[7] * g.y + d[8] * g.z};
}

// (level − f) / |∇f| at `world`, clamped to ±limit_mm (outside, where f < level, positive).
template <class T>
double first_order_signed_distance(const Volume<T>& field, double level, const Vec3& world,
                                   double limit_mm) {
  const Vec3 index = field.grid.world_to_index(world);
  const double f = double(sample_trilinear(field, index)) - level;
  const double g = norm(world_gradient(field, index));
  if (!(g > 1e-12)) return f > 0 ? -limit_mm : limit_mm;
  return std::clamp(-f / g, -limit_mm, limit_mm);
}

}  // namespace

double MaskSurface::signed_distance(const Vec3& world, double limit_mm) const {
  return first_order_signed_distance(*mask_, 0.5, world, limit_mm);
}

double MaskSurface::max_spacing_mm() const {
  const Vec3& s = mask_->grid.spacing;
  return std::max({s.x, s.y, s.z});
}

double LevelSetSurface::min_spacing_mm() const {
  const Vec3& s = field_->grid.spacing;
  return std::min({s.x, s.y, s.z});
}

double LevelSetSurface::max_spacing_mm() const {
  const Vec3& s = field_->grid.spacing;
  return std::max({s.x, s.y, s.z});
}

double LevelSetSurface::signed_distance(const Vec3& world, double limit_mm) const {
  return first_order_signed_distance(*field_, level_, world, limit_mm);
}

bool LevelSetSurface::project(Vec3& world, double max_move_mm) const {
  const Grid& g = field_->grid;
  Vec3 index = g.world_to_index(world);
  const double max_spacing = std::max({g.spacing.x, g.spacing.y, g.spacing.z});
  if (!project_to_level_set(*field_, level_, index, max_move_mm / max_spacing)) return false;
  const Vec3 moved = g.index_to_world(index);
  if (cvt::distance(moved, world) > max_move_mm) return false;
  world = moved;
  return true;
}

Vec3 LevelSetSurface::unit_normal(const Vec3& world) const {
  const Vec3 grad = world_gradient(*field_, field_->grid.world_to_index(world));
  const double n = norm(grad);
  return n > 0 ? grad / n : Vec3{0, 0, 0};
}

double LevelSetSurface::distance(const Vec3& world) const {
  // Near the surface the first-order estimate is accurate (and the projection, which stops
  // once |f − level| < 1e-4, would report 0); farther out, follow the projection.
  const Vec3 index = field_->grid.world_to_index(world);
  const double f = double(sample_trilinear(*field_, index)) - level_;
  const double g = norm(world_gradient(*field_, index));
  const double estimate = g > 1e-12 ? std::abs(f) / g : std::numeric_limits<double>::infinity();
  if (estimate <= 0.1 * min_spacing_mm()) return estimate;
  const double limit = 20.0 * min_spacing_mm();
  Vec3 p = world;
  if (project(p, limit)) return cvt::distance(p, world);
  return std::min(estimate, limit);
}

}  // namespace cvt::opt
