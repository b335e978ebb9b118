// Stage 6, vertex insertion: where neither flips nor moves help — a tiny boundary triangle whose
// tets reach a far interior vertex (needles), or two short boundary edges facing each other
// across a thick part with no vertex between them (wedges) — a new interior vertex is inserted.
// The tets around it form a cavity, grown greedily from the tet containing it while that raises
// the worst new tet (after Klingner & Shewchuk), and the cavity is re-triangulated as a star from
// the new vertex. Candidate points: the bad tet's centroid (best in ~90 % of insertions on the
// liver), its circumcentre, and the apex of a regular tet on its smallest face. The best star is
// kept, and only when its worst tet beats the worst tet it replaces. Every new tet is positively
// oriented and the cavity's boundary is kept (no vertex may disappear into it): validity holds.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "optimize/mesh_optimization_work.h"

namespace cvt::opt {
namespace {

// Circumcentre and squared radius of tet (a, b, c, d); false when flat.
bool circumsphere(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, Vec3& centre,
                  double& r2) {
  const Vec3 ab = b - a, ac = c - a, ad = d - a;
  const double vol6 = dot(ab, cross(ac, ad));
  if (!(std::abs(vol6) > 0)) return false;
  const Vec3 rel =
      (cross(ac, ad) * dot(ab, ab) + cross(ad, ab) * dot(ac, ac) + cross(ab, ac) * dot(ad, ad)) /
      (2.0 * vol6);
  centre = a + rel;
  r2 = dot(rel, rel);
  return std::isfinite(r2);
}

struct Cavity {
  std::vector<std::int32_t> tets;  // removed
  std::vector<Triangle> faces;     // its boundary, oriented out of the cavity
  std::vector<double> quality;     // of the new tets (p, face)
  double new_min = -1;
};

// The tet across face f of tet t (−1 on the boundary).
std::int32_t neighbour(const WorkMesh& m, std::int32_t t, int f, std::vector<std::int32_t>& buf) {
  const Triangle face = outward_faces(m.tets[t])[f];
  m.tets_with(face.data(), 3, buf);
  for (std::int32_t u : buf)
    if (u != t) return u;
  return -1;
}

// The star of p over a cavity grown from the tet containing p (found by walking from `seed`,
// which must end in the cavity): while the worst new tet (p, face) can be improved by taking the
// tet behind that face into the cavity, it is taken (Klingner & Shewchuk's cavity growth, greedy).
// False when p is not inside the mesh near the seed, some new tet is not better than `floor`, or
// the cavity would swallow a vertex.
bool build_cavity(const WorkMesh& m, std::int32_t seed, const Vec3& p, int max_tets, double floor,
                  Cavity& cav) {
  std::vector<std::int32_t> buf;
  // Walk to the tet containing p.
  std::int32_t at = seed;
  for (int step = 0;; ++step) {
    if (step > 8) return false;
    const auto faces = outward_faces(m.tets[at]);
    int exit = -1;
    for (int f = 0; f < 4 && exit < 0; ++f) {
      const Vec3 &x = m.pos[faces[f][0]], &y = m.pos[faces[f][1]], &z = m.pos[faces[f][2]];
      if (dot(y - x, cross(z - x, p - x)) > 0) exit = f;  // p beyond this face
    }
    if (exit < 0) break;
    at = neighbour(m, at, exit, buf);
    if (at < 0 || m.labels[at] != m.labels[seed]) return false;
  }
  // Cavity faces: (face, tet behind it or −1, quality of (p, face)).
  struct Face {
    Triangle f;
    std::int32_t behind;
    double q;
  };
  thread_local std::vector<Face> faces, saved;
  faces.clear();
  auto same_face = [](const Triangle& a, const Triangle& b) {
    Triangle x = a, y = b;
    std::sort(x.begin(), x.end());
    std::sort(y.begin(), y.end());
    return x == y;
  };
  // Adds tet t (just put in cav.tets): its faces shared with the cavity become interior.
  auto add_tet_faces = [&](std::int32_t t) {
    const auto fs = outward_faces(m.tets[t]);
    for (int i = 0; i < 4; ++i) {
      const std::int32_t n = neighbour(m, t, i, buf);
      if (n >= 0 && std::find(cav.tets.begin(), cav.tets.end(), n) != cav.tets.end()) {
        for (std::size_t k = 0; k < faces.size(); ++k)
          if (faces[k].behind == t && same_face(faces[k].f, fs[i])) {
            faces[k] = faces.back();
            faces.pop_back();
            break;
          }
        continue;
      }
      faces.push_back(
          {fs[i], n, m.tet_quality(p, m.pos[fs[i][0]], m.pos[fs[i][1]], m.pos[fs[i][2]])});
    }
  };
  cav.tets.assign(1, at);
  add_tet_faces(at);
  auto worst = [&] {
    std::size_t w = 0;
    for (std::size_t k = 1; k < faces.size(); ++k)
      if (faces[k].q < faces[w].q) w = k;
    return w;
  };
  while (int(cav.tets.size()) < max_tets) {
    const std::size_t w = worst();
    if (faces[w].q > floor && std::find(cav.tets.begin(), cav.tets.end(), seed) != cav.tets.end())
      break;  // good enough
    const std::int32_t n = faces[w].behind;
    if (n < 0 || m.labels[n] != m.labels[seed]) break;
    if (std::find(cav.tets.begin(), cav.tets.end(), n) != cav.tets.end()) break;
    const double before = faces[w].q;
    saved.assign(faces.begin(), faces.end());
    cav.tets.push_back(n);
    add_tet_faces(n);
    if (!(faces[worst()].q > before) &&
        std::find(cav.tets.begin(), cav.tets.end(), seed) == cav.tets.end() && n != seed) {
      faces.swap(saved);  // no better: undo and stop
      cav.tets.pop_back();
      break;
    }
  }
  if (std::find(cav.tets.begin(), cav.tets.end(), seed) == cav.tets.end()) return false;
  cav.faces.clear();
  cav.quality.clear();
  cav.new_min = std::numeric_limits<double>::infinity();
  thread_local std::vector<std::int32_t> vertices, on_faces;
  vertices.clear();
  on_faces.clear();
  for (std::int32_t t : cav.tets)
    for (std::int32_t v : m.tets[t]) vertices.push_back(v);
  for (const Face& f : faces) {
    if (!(f.q > floor)) return false;
    cav.new_min = std::min(cav.new_min, f.q);
    cav.faces.push_back(f.f);
    cav.quality.push_back(f.q);
    for (std::int32_t v : f.f) on_faces.push_back(v);
  }
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  std::sort(on_faces.begin(), on_faces.end());
  on_faces.erase(std::unique(on_faces.begin(), on_faces.end()), on_faces.end());
  return vertices.size() == on_faces.size();
}

// Appends an interior vertex and returns its index.
std::int32_t add_vertex(WorkMesh& m, const Vec3& x) {
  const std::int32_t v = std::int32_t(m.pos.size());
  m.pos.push_back(x);
  m.vertex_tets.emplace_back();
  m.on_boundary.push_back(0);
  if (!m.on_surface.empty()) m.on_surface.push_back(0);
  m.vertex_stamp.push_back(m.clock);
  m.move_failed.push_back(0);
  return v;
}

// The best insertion into bad tet t (best.new_min < 0: none helps).
struct InsertPlan {
  Cavity best;
  Vec3 point;
  std::vector<Tet> old_content;  // the cavity's tets when planned
  bool tried = false;
};

void plan_insertion(const WorkMesh& m, std::int32_t t, const InsertionOptions& o,
                    InsertPlan& plan) {
  plan.tried = true;
  plan.best.new_min = -1;
  const Tet tet = m.tets[t];
  const Vec3 p[4] = {m.pos[tet[0]], m.pos[tet[1]], m.pos[tet[2]], m.pos[tet[3]]};
  // Candidate points: the centroid (best most often, by far), the circumcentre, and the apex
  // of a regular tet on the smallest face (for needles standing on a tiny triangle).
  std::vector<Vec3> candidates{(p[0] + p[1] + p[2] + p[3]) * 0.25};
  Vec3 centre;
  double r2;
  if (circumsphere(p[0], p[1], p[2], p[3], centre, r2)) candidates.push_back(centre);
  const auto faces = outward_faces(tet);
  int smallest = -1;
  double smallest_area = std::numeric_limits<double>::infinity();
  for (int f = 0; f < 4; ++f) {
    const Vec3 &x = m.pos[faces[f][0]], &y = m.pos[faces[f][1]], &z = m.pos[faces[f][2]];
    const double area = norm(cross(y - x, z - x));
    if (area < smallest_area) smallest_area = area, smallest = f;
  }
  if (smallest_area > 0) {
    const Triangle& f = faces[smallest];
    const Vec3 &x = m.pos[f[0]], &y = m.pos[f[1]], &z = m.pos[f[2]];
    const Vec3 n = cross(y - x, z - x) / smallest_area;  // unit, outward
    const double edge = (distance(x, y) + distance(y, z) + distance(z, x)) / 3.0;
    candidates.push_back((x + y + z) / 3.0 - n * (std::sqrt(2.0 / 3.0) * edge));
  }
  Cavity cav;
  for (const Vec3& c : candidates) {
    const double floor = std::max({m.quality[t], plan.best.new_min, kMinValidQuality});
    if (!build_cavity(m, t, c, o.max_cavity_tets, floor, cav)) continue;
    // The worst tet removed must be beaten too.
    double old_min = std::numeric_limits<double>::infinity();
    for (std::int32_t u : cav.tets) old_min = std::min(old_min, m.quality[u]);
    if (!(cav.new_min > old_min)) continue;
    std::swap(plan.best, cav);
    plan.point = c;
  }
  if (plan.best.new_min >= 0)
    for (std::int32_t u : plan.best.tets) plan.old_content.push_back(m.tets[u]);
}

}  // namespace

PassCounts insert_vertices(WorkMesh& m, const InsertionOptions& o) {
  PassCounts counts;
  std::vector<std::pair<double, std::int32_t>> bad;
  std::vector<InsertPlan> plans;
  for (int round = 0; round < o.max_rounds; ++round) {
    bad.clear();
    for (std::size_t t = 0; t < m.tets.size(); ++t)
      if (!is_dead(m.tets[t]) && m.quality[t] < o.bad_below &&
          m.changed_since(std::int32_t(t), m.insert_failed[t]))  // else it failed, unchanged
        bad.push_back({m.quality[t], std::int32_t(t)});
    if (bad.empty()) break;
    std::sort(bad.begin(), bad.end());
    // In chunks: planned in parallel on the mesh as it is, applied in order while the cavity
    // is as planned (else planned again in the next round): the result does not depend on the
    // thread count.
    constexpr std::size_t kChunk = 64;
    std::size_t inserted = 0;
    for (std::size_t first = 0; first < bad.size(); first += kChunk) {
      m.check_cancelled();
      const std::size_t count = std::min(kChunk, bad.size() - first);
      const std::uint64_t planned_at = m.clock;
      plans.assign(count, InsertPlan{});
      tbb::parallel_for(std::size_t(0), count, [&](std::size_t k) {
        const std::int32_t t = bad[first + k].second;
        if (!is_dead(m.tets[t]) && m.quality[t] < o.bad_below) plan_insertion(m, t, o, plans[k]);
      });
      for (std::size_t k = 0; k < count; ++k) {
        const std::int32_t t = bad[first + k].second;
        const InsertPlan& plan = plans[k];
        if (!plan.tried) continue;
        if (plan.best.new_min < 0) {
          m.insert_failed[t] = planned_at;
          continue;
        }
        bool valid = true;
        for (std::size_t i = 0; i < plan.best.tets.size() && valid; ++i)
          valid = m.tets[plan.best.tets[i]] == plan.old_content[i];
        if (!valid) continue;
        const std::int32_t label = m.labels[t];
        const std::int32_t v = add_vertex(m, plan.point);
        for (std::int32_t u : plan.best.tets) m.remove_tet(u);
        for (std::size_t i = 0; i < plan.best.faces.size(); ++i) {
          const Triangle& f = plan.best.faces[i];
          m.add_tet({v, f[0], f[1], f[2]}, label, plan.best.quality[i]);
        }
        ++inserted;
      }
    }
    counts.inserted += inserted;
    if (inserted == 0) break;
  }
  return counts;
}

}  // namespace cvt::opt
