// Stage 6, in its second and third passes: boundary vertices where the segmentation departs
// from the mesh. Stage 2 spaces the surface samples by r·lfs, which follows the segmentation's
// smooth parts but cuts across its voxel-scale detail (where a thick slice ends on a nearly
// level surface, a ridge, a groove); there the mesh misses the boundary by up to a voxel, which
// no vertex move can mend. Where a point of the segmentation's boundary lies farther than a
// tolerance from the mesh boundary, the boundary edge nearest it is split and the new vertex
// moved onto the surface, farthest points first — as Delaunay refinement inserts a surface point
// where a facet lies farther than its distance bound (CGAL Mesh_3's facet_distance). The split
// only halves tets, and the move is checked as every boundary move is (its star stays embedded),
// so the boundary keeps its topology; the passes that follow work on the new tets like on any
// other.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "base/point_grid.h"
#include "evaluate/triangle_grid.h"
#include "optimize/mesh_optimization_work.h"

namespace cvt::opt {
namespace {

constexpr int kSweeps = 3;

using FarPoint = BoundaryRefiner::FarPoint;

// The points of the segmentation's boundary (its mask's 0.5 level on the edges between voxel
// centres, where marching cubes puts its vertices) farther than `tolerance_mm` from the
// boundary faces, farthest first (ties in scan order).
std::vector<FarPoint> far_points(const Mask& object, const TriangleSurface& boundary,
                                 double tolerance_mm) {
  const TriangleGrid triangles(boundary);
  const Grid& grid = object.grid;
  const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
  const std::size_t row = std::size_t(nx), slice = row * std::size_t(ny);
  const unsigned char* data = object.data.data();
  std::vector<std::vector<FarPoint>> slabs(std::size_t(std::max(nz, 0)));
  tbb::parallel_for(0, nz, [&](int k) {
    std::int32_t hint = -1;
    const double tolerance2 = tolerance_mm * tolerance_mm;
    auto check = [&](double i, double j, double kk) {
      const Vec3 p = grid.index_to_world(Vec3{i, j, kk});
      // Most points lie within the tolerance of the face nearest the point before: no search.
      if (hint >= 0) {
        const Triangle& t = boundary.triangles[std::size_t(hint)];
        if (point_triangle_squared_distance(p, boundary.vertices[t[0]], boundary.vertices[t[1]],
                                            boundary.vertices[t[2]]) <= tolerance2)
          return;
      }
      const double d2 = triangles.squared_distance(p, &hint);
      if (d2 > tolerance2)
        slabs[std::size_t(k)].push_back({std::sqrt(d2), p, hint});
    };
    for (int j = 0; j < ny; ++j) {
      const unsigned char* v = data + std::size_t(k) * slice + std::size_t(j) * row;
      for (int i = 0; i < nx; ++i) {
        const bool in = v[i] != 0;
        // Outside the grid is background, as for marching cubes.
        if ((i + 1 < nx && v[i + 1] != 0) != in) check(i + 0.5, j, k);
        if ((j + 1 < ny && v[i + row] != 0) != in) check(i, j + 0.5, k);
        if ((k + 1 < nz && v[i + slice] != 0) != in) check(i, j, k + 0.5);
      }
    }
  });
  std::vector<FarPoint> out;
  for (const auto& slab : slabs) out.insert(out.end(), slab.begin(), slab.end());
  std::stable_sort(out.begin(), out.end(),
                   [](const FarPoint& a, const FarPoint& b) { return a.distance > b.distance; });
  return out;
}

// Moves x onto the surface, within a hundredth of a voxel (where the vertices that slide on it
// are kept), or returns false.
bool project_precisely(const LevelSetSurface& surface, Vec3& x) {
  return surface.project(x, 2 * surface.max_spacing_mm()) &&
         surface.distance(x) <= 0.01 * surface.min_spacing_mm();
}

// Moves new boundary vertex v towards x on the surface, checked as any boundary move (its star
// kept embedded, no tet made bad: move_boundary_vertex), and keeps the move when its worst tet
// ends above `better_than`; with `whole`, only the whole way. False: nothing changed. A vertex
// moved part of the way is off the surface: the passes' snap brings it on, to within its
// tolerance.
bool move_onto(WorkMesh& m, std::int32_t v, const Vec3& x, double bad_below, bool whole,
               std::vector<double>& star_quality,
               double better_than = -std::numeric_limits<double>::infinity()) {
  star_quality.resize(m.vertex_tets[v].size());
  const Move move = move_boundary_vertex(m, v, x, bad_below, star_quality.data());
  if (!move.moved || (whole && !(move.position == x)) ||
      !(*std::min_element(star_quality.begin(), star_quality.end()) > better_than))
    return false;
  m.pos[v] = move.position;
  for (std::size_t k = 0; k < star_quality.size(); ++k) m.quality[m.vertex_tets[v][k]] = star_quality[k];
  m.touch_star(v);
  if (!m.on_surface.empty()) m.on_surface[v] = move.position == x;
  return true;
}

// A boundary edge split at a point of it: the old tets of its ring (each halved, so the new ones
// are positive and the boundary keeps its shape) and the slots of the new ones.
struct Split {
  std::int32_t vertex = -1;
  std::vector<Tet> old_tets;
  std::vector<std::int32_t> old_labels, new_slots;
  std::vector<double> old_quality;
};

// Splits boundary edge (a, b), whose open ring is given (WorkMesh::edge_ring), at the point x of
// it, when every new tet is better than `floor`; split.vertex −1 (nothing changed) otherwise.
Split split_edge(WorkMesh& m, std::int32_t a, std::int32_t b, const Vec3& x, double floor,
                 const std::vector<std::int32_t>& ring, const std::vector<std::int32_t>& ring_tets) {
  Split split;
  std::vector<double> q(2 * ring_tets.size());
  for (std::size_t i = 0; i < ring_tets.size(); ++i) {
    const Vec3 &c = m.pos[ring[i]], &d = m.pos[ring[i + 1]];
    q[2 * i] = m.tet_quality(x, m.pos[b], c, d, floor);
    q[2 * i + 1] = m.tet_quality(m.pos[a], x, c, d, floor);
    if (!(q[2 * i] > floor) || !(q[2 * i + 1] > floor)) return split;
  }
  const auto v = std::int32_t(m.pos.size());
  m.pos.push_back(x);
  m.vertex_tets.emplace_back();
  m.on_boundary.push_back(1);
  if (!m.on_surface.empty()) m.on_surface.push_back(0);  // on the chord, not on the surface
  m.vertex_stamp.push_back(m.clock);
  m.move_failed.push_back(0);
  split.vertex = v;
  for (std::size_t i = 0; i < ring_tets.size(); ++i) {
    const std::int32_t t = ring_tets[i];
    split.old_tets.push_back(m.tets[t]);
    split.old_labels.push_back(m.labels[t]);
    split.old_quality.push_back(m.quality[t]);
    m.remove_tet(t);
    split.new_slots.push_back(m.add_tet({v, b, ring[i], ring[i + 1]}, split.old_labels[i], q[2 * i]));
    split.new_slots.push_back(
        m.add_tet({a, v, ring[i], ring[i + 1]}, split.old_labels[i], q[2 * i + 1]));
  }
  return split;
}

// Undoes the split just made: the old tets back, the new vertex (the last one) gone.
void undo(WorkMesh& m, const Split& split) {
  for (std::int32_t t : split.new_slots) m.remove_tet(t);
  for (std::size_t i = 0; i < split.old_tets.size(); ++i)
    m.add_tet(split.old_tets[i], split.old_labels[i], split.old_quality[i]);
  m.pos.pop_back();
  m.vertex_tets.pop_back();
  m.on_boundary.pop_back();
  if (!m.on_surface.empty()) m.on_surface.pop_back();
  m.vertex_stamp.pop_back();
  m.move_failed.pop_back();
}

}  // namespace

BoundaryRefinement BoundaryRefiner::run(WorkMesh& m, const BoundaryRefinementOptions& o) {
  BoundaryRefinement out;
  if (!(o.tolerance_mm > 0) || o.max_inserted == 0) return out;
  std::vector<Triangle> faces = boundary_faces(m);
  if (faces.empty()) return out;
  const bool first = !scanned_;
  if (first) {
    far_ = far_points(*object_, TriangleSurface{m.pos, faces}, o.tolerance_mm);
    scanned_ = true;
  }
  std::vector<std::int32_t> with_face, ring, ring_tets;
  std::vector<FarPoint> retry;
  std::vector<double> star_quality;
  // Points whose nearest face an earlier split replaced wait for the next sweep.
  for (int sweep = 0; sweep < kSweeps && !far_.empty() && out.inserted < o.max_inserted; ++sweep) {
    if (sweep > 0 || !first) {  // the points left, against the boundary as it is now
      if (sweep > 0) faces = boundary_faces(m);
      const TriangleSurface boundary{m.pos, faces};
      const TriangleGrid triangles(boundary);
      std::vector<char> keep(far_.size(), 0);
      tbb::parallel_for(std::size_t(0), far_.size(), [&](std::size_t n) {
        std::int32_t face = -1;
        const double d2 = triangles.squared_distance(far_[n].at, &face);
        keep[n] = d2 > o.tolerance_mm * o.tolerance_mm;
        far_[n].distance = std::sqrt(d2);
        far_[n].face = face;
      });
      std::vector<FarPoint> left;
      for (std::size_t n = 0; n < far_.size(); ++n)
        if (keep[n]) left.push_back(far_[n]);
      std::stable_sort(left.begin(), left.end(),
                       [](const FarPoint& a, const FarPoint& b) { return a.distance > b.distance; });
      far_ = std::move(left);
    }
    if (sweep == 0) out.far_points = far_.size();
    // Farthest first, one per spacing.
    std::vector<Vec3> at;
    at.reserve(far_.size());
    for (const FarPoint& f : far_) at.push_back(f.at);
    const PointGrid candidates(at, o.spacing_mm);
    std::vector<char> chosen(far_.size(), 0), tried(far_.size(), 0);
    std::size_t inserted = 0;
    for (std::size_t n = 0; n < far_.size() && out.inserted + inserted < o.max_inserted; ++n) {
      if (candidates.any_within(at[n], o.spacing_mm, [&](std::int32_t k) { return chosen[k] != 0; }))
        continue;
      chosen[n] = 1;
      const Triangle f = faces[std::size_t(far_[n].face)];
      m.tets_with(f.data(), 3, with_face);
      if (with_face.size() != 1) continue;  // split already: next sweep
      tried[n] = 1;
      // The edge of the face nearest the point is split at the point's foot on it (kept off
      // its ends), and the new vertex moved to where the surface is nearest the point. (Over
      // the face, the edges rank alike by their distance to the point and to its foot on the
      // face, and the feet on an edge coincide.)
      const Vec3& p = far_[n].at;
      int e = 0;
      double best = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        const Vec3 &p0 = m.pos[f[k]], &p1 = m.pos[f[(k + 1) % 3]];
        const double t = std::clamp(dot(p - p0, p1 - p0) / squared_distance(p0, p1), 0.0, 1.0);
        const double d = squared_distance(p, p0 + (p1 - p0) * t);
        if (d < best) best = d, e = k;
      }
      const std::int32_t u = f[e], w = f[(e + 1) % 3];
      const double t = std::clamp(
          dot(p - m.pos[u], m.pos[w] - m.pos[u]) / squared_distance(m.pos[u], m.pos[w]), 0.25, 0.75);
      Vec3 x = p;
      if (!project_precisely(*surface_, x)) continue;
      if (m.edge_ring(u, w, ring, ring_tets) != WorkMesh::Ring::open) continue;
      // The halved tets: not flat, and better than bad or than the worst they replace.
      double floor = o.bad_below;
      for (std::int32_t r : ring_tets) floor = std::min(floor, m.quality[r]);
      floor = std::max(floor, kMinValidQuality);
      const Split split =
          split_edge(m, u, w, m.pos[u] + (m.pos[w] - m.pos[u]) * t, floor, ring, ring_tets);
      if (split.vertex < 0) continue;
      // Then the new vertex towards the surface point (part of the way will do: the fidelity
      // gained is most of it); else the split is undone.
      if (!move_onto(m, split.vertex, x, o.bad_below, false, star_quality)) {
        undo(m, split);
        continue;
      }
      ++inserted;
    }
    out.inserted += inserted;
    // A point tried is not tried again in this run; in the next, the tets around it may be
    // better.
    std::vector<FarPoint> left;
    for (std::size_t n = 0; n < far_.size(); ++n)
      (tried[n] ? retry : left).push_back(far_[n]);
    far_ = std::move(left);
    if (inserted == 0) break;
  }
  far_.insert(far_.end(), retry.begin(), retry.end());
  return out;
}

PassCounts split_bad_caps(WorkMesh& m, const LevelSetSurface& surface, double bad_below) {
  PassCounts counts;
  // Bad tets with two boundary faces, worst first (stable: slot order among equals).
  std::vector<std::pair<double, std::int32_t>> caps;
  std::vector<std::int32_t> with_face;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    const Tet& tet = m.tets[t];
    if (is_dead(tet) || !(m.quality[t] < bad_below)) continue;
    if (!m.on_boundary[tet[0]] || !m.on_boundary[tet[1]] || !m.on_boundary[tet[2]] ||
        !m.on_boundary[tet[3]])
      continue;
    caps.push_back({m.quality[t], std::int32_t(t)});
  }
  std::stable_sort(caps.begin(), caps.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::int32_t> ring, ring_tets;
  std::vector<double> star_quality;
  for (const auto& [q, t] : caps) {
    if (is_dead(m.tets[t]) || m.quality[t] != q) continue;  // changed by a split before
    const Tet tet = m.tets[t];
    // The faces on the boundary (face i is opposite vertex i); two of them meet at the ridge.
    int boundary[4], n = 0;
    for (int i = 0; i < 4; ++i) {
      const Triangle f = outward_faces(tet)[i];
      m.tets_with(f.data(), 3, with_face);
      if (with_face.size() == 1) boundary[n++] = i;
    }
    if (n != 2) continue;
    std::int32_t edge[2], k = 0;
    for (int i = 0; i < 4; ++i)
      if (i != boundary[0] && i != boundary[1]) edge[k++] = tet[i];
    if (m.edge_ring(edge[0], edge[1], ring, ring_tets) != WorkMesh::Ring::open) continue;
    double old_min = std::numeric_limits<double>::infinity();
    for (std::int32_t r : ring_tets) old_min = std::min(old_min, m.quality[r]);
    const Vec3 mid = (m.pos[edge[0]] + m.pos[edge[1]]) * 0.5;
    Vec3 x = mid;
    if (!project_precisely(surface, x)) continue;
    const Split split = split_edge(m, edge[0], edge[1], mid, kMinValidQuality, ring, ring_tets);
    if (split.vertex < 0) continue;
    // A cap is fixed only with its ridge on the surface; the split alone leaves it flat.
    if (!move_onto(m, split.vertex, x, bad_below, true, star_quality, old_min)) {
      undo(m, split);
      continue;
    }
    ++counts.split_caps;
  }
  return counts;
}

}  // namespace cvt::opt
