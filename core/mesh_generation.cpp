#include "mesh_generation.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/property_map.h>
#include <CGAL/spatial_sort.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include "errors.h"
#include "manifold_repair.h"

namespace cvt {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_3<int, Kernel>;
// Cells carry their fate under rules 1–2 (CellFate), and what rules 1 and 2 alone make of
// them, which depends only on the cell's corners: a cell that survives a pinched sample's
// removal keeps it, so only new cells are tested again. The Delaunay base has circumcenter().
enum class CellTest : signed char { untested, inside, pole, outside };
struct CellInfo {
  int fate = 0;  // a CellFate, negated while restore_enclosed marks cells
  CellTest test = CellTest::untested;
};
using CellBase = CGAL::Triangulation_cell_base_with_info_3<
    CellInfo, Kernel, CGAL::Delaunay_triangulation_cell_base_3<Kernel>>;
using DataStructure = CGAL::Triangulation_data_structure_3<VertexBase, CellBase>;
using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, DataStructure>;
using Point = Kernel::Point_3;

enum CellFate : int { kept_cell, pole_cell, outside_cell };

Point to_point(const Vec3& v) { return {v.x, v.y, v.z}; }
Vec3 to_vec(const Point& p) { return {p.x(), p.y(), p.z()}; }

Delaunay triangulate(const std::vector<std::pair<Point, int>>& points, const Progress& progress) {
  // CGAL's range insertion, step for step (spatial sort, then each point from the previous
  // one's vertex), so the triangulation is the same; but it takes ~0.3 s on the liver, so a
  // cancel is checked every few thousand points. With distinct inputs the result is unique up
  // to cospherical degeneracies, which CGAL resolves by symbolic perturbation (deterministic).
  std::vector<Point> p;
  p.reserve(points.size());
  for (const auto& [point, info] : points) p.push_back(point);
  std::vector<std::size_t> order(points.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  using SortTraits =
      CGAL::Spatial_sort_traits_adapter_3<Kernel, CGAL::Pointer_property_map<Point>::type>;
  CGAL::spatial_sort(order.begin(), order.end(), SortTraits(CGAL::make_property_map(p), Kernel()));
  Delaunay dt;
  Delaunay::Vertex_handle hint;
  for (std::size_t n = 0; n < order.size(); ++n) {
    if (n % 4096 == 0) progress.check_cancelled();
    hint = dt.insert(p[order[n]], hint);
    if (hint != Delaunay::Vertex_handle()) hint->info() = points[order[n]].second;
  }
  return dt;
}

double bounding_diagonal(const std::vector<Vec3>& pts) {
  Vec3 lo = pts[0], hi = pts[0];
  for (const Vec3& p : pts)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  return distance(lo, hi);
}

// Rotates t so its smallest index comes first while keeping the orientation (an even
// permutation), so equal meshes give equal tet lists whatever order CGAL visits cells in.
Tet canonical(Tet t) {
  const int m = int(std::min_element(t.begin(), t.end()) - t.begin());
  static const int even[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
  Tet r{t[even[m][0]], t[even[m][1]], t[even[m][2]], t[even[m][3]]};
  // Among the 3 even rotations of the last three, put the smallest second.
  for (int k = 0; k < 3 && !(r[1] < r[2] && r[1] < r[3]); ++k) r = {r[0], r[2], r[3], r[1]};
  return r;
}

// A deterministic offset in [−j, j]³ from a splitmix64 hash of (seed, index).
Vec3 jitter(int index, const MeshGenerationOptions& options) {
  std::uint64_t x = options.seed * 0x9E3779B97F4A7C15ULL + std::uint64_t(index);
  Vec3 out;
  for (int a = 0; a < 3; ++a) {
    x += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = x;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    out[a] = (double(z >> 11) / double(1ULL << 53) * 2.0 - 1.0) * options.interior_jitter_mm;
  }
  return out;
}

// Rule 2: the centroid's occupancy decides. Large tets need only reach inside_from (one that
// straddles a notch would expose faces deep inside); small ones must be inside (≥ 0.5), since
// in a channel narrower than the smoothing the indicator never drops to inside_from.
bool centroid_outside(Delaunay::Cell_handle c, const OccupancyFunction& occupancy,
                      const MeshGenerationOptions& options) {
  std::array<Vec3, 4> p;
  Vec3 centroid{0, 0, 0};
  for (int k = 0; k < 4; ++k) centroid += p[k] = to_vec(c->vertex(k)->point());
  double longest2 = 0;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) longest2 = std::max(longest2, squared_distance(p[a], p[b]));
  const bool small = longest2 < options.small_tet_edge_mm * options.small_tet_edge_mm;
  return occupancy(centroid / 4.0) < (small ? 0.5 : options.inside_from);
}

// Rule 2 only carves what the outside reaches: cells it removed that are enclosed by kept cells
// (not connected through removed cells to a pole's cell or the hull) are kept again, as a void
// there would be an artefact of the centroid test, not a cavity of the object (those hold
// exterior poles).
void restore_enclosed(const Delaunay& dt, const std::vector<Delaunay::Cell_handle>& outside) {
  std::vector<Delaunay::Cell_handle> reached;
  for (Delaunay::Cell_handle c : outside)
    for (int k = 0; k < 4; ++k) {
      const Delaunay::Cell_handle n = c->neighbor(k);
      if (dt.is_infinite(n) || n->info().fate == pole_cell) {
        c->info().fate = -outside_cell;  // reached: marked by the sign until the end
        reached.push_back(c);
        break;
      }
    }
  for (std::size_t q = 0; q < reached.size(); ++q)
    for (int k = 0; k < 4; ++k) {
      const Delaunay::Cell_handle n = reached[q]->neighbor(k);
      if (!dt.is_infinite(n) && n->info().fate == outside_cell) {
        n->info().fate = -outside_cell;
        reached.push_back(n);
      }
    }
  for (Delaunay::Cell_handle c : outside)
    c->info().fate = c->info().fate == -outside_cell ? outside_cell : kept_cell;
}

// Faces between kept cells and the rest (removed cells or the hull), as sample indices.
std::vector<Triangle> kept_boundary(const Delaunay& dt) {
  std::vector<Triangle> faces;
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    if (c->info().fate != kept_cell) continue;
    for (int k = 0; k < 4; ++k) {
      const Delaunay::Cell_handle n = c->neighbor(k);
      if (!dt.is_infinite(n) && n->info().fate == kept_cell) continue;
      faces.push_back({c->vertex((k + 1) & 3)->info(), c->vertex((k + 2) & 3)->info(),
                       c->vertex((k + 3) & 3)->info()});
    }
  }
  return faces;
}

}  // namespace

std::vector<Vec3> compute_poles(const std::vector<Vec3>& surface, const Progress& progress) {
  std::vector<std::pair<Point, int>> pts;
  pts.reserve(surface.size());
  for (std::size_t i = 0; i < surface.size(); ++i) pts.push_back({to_point(surface[i]), int(i)});
  const Delaunay dt = triangulate(pts, progress);
  const double far = 4.0 * bounding_diagonal(surface);
  Vec3 centroid{0, 0, 0};
  for (const Vec3& p : surface) centroid += p;
  centroid = centroid / double(surface.size());
  std::vector<Vec3> poles;
  std::vector<Delaunay::Cell_handle> cells;
  for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v) {
    const Vec3 s = to_vec(v->point());
    cells.clear();
    dt.incident_cells(v, std::back_inserter(cells));
    Vec3 outward{0, 0, 0};
    bool on_hull = false;
    double best = -1;
    Vec3 first{};
    for (auto c : cells) {
      if (dt.is_infinite(c)) {
        // The hull facet of this infinite cell; its outward normal points away from the hull.
        on_hull = true;
        const int inf = c->index(dt.infinite_vertex());
        const Vec3 a = to_vec(c->vertex((inf + 1) & 3)->point()),
                   b = to_vec(c->vertex((inf + 2) & 3)->point()),
                   d = to_vec(c->vertex((inf + 3) & 3)->point());
        Vec3 n = cross(b - a, d - a);
        // The hull is convex, so the point set's centroid lies behind every hull facet.
        if (dot(n, a - centroid) < 0) n = n * -1.0;
        outward += n;
        continue;
      }
      const Vec3 centre = to_vec(dt.dual(c));
      const double d2 = squared_distance(centre, s);
      if (d2 > best) {
        best = d2;
        first = centre;
      }
    }
    Vec3 direction;
    if (on_hull) {
      const double len = norm(outward);
      if (len == 0) continue;
      direction = outward / len;
      first = s + direction * far;
    } else {
      direction = first - s;
    }
    poles.push_back(first);
    // The second pole: the farthest Voronoi vertex on the other side of s.
    double second_best = -1;
    Vec3 second{};
    for (auto c : cells) {
      if (dt.is_infinite(c)) continue;
      const Vec3 centre = to_vec(dt.dual(c));
      if (dot(centre - s, direction) >= 0) continue;
      const double d2 = squared_distance(centre, s);
      if (d2 > second_best) {
        second_best = d2;
        second = centre;
      }
    }
    if (second_best > 0) poles.push_back(second);
  }
  return poles;
}

MeshGenerationResult build_delaunay_mesh(const std::vector<Vec3>& surface,
                                         const std::vector<Vec3>& interior,
                                         const OccupancyFunction& occupancy,
                                         const MeshGenerationOptions& options,
                                         const Progress& progress) {
  if (surface.size() < 4) throw InputError("mesh generation: fewer than 4 surface samples");
  MeshGenerationResult out;
  progress("poles", 0.0);
  for (const Vec3& pole : compute_poles(surface, progress)) {
    const double o = occupancy(pole);
    if (o >= options.inside_from)
      out.interior_poles.push_back(pole);
    else if (o < options.pole_outside_below)
      out.exterior_poles.push_back(pole);
    else
      ++out.near_surface_poles;
  }

  progress("Delaunay", 0.3);
  const int nb = int(surface.size()), ni = int(interior.size());
  std::vector<Vec3> nudged(interior);
  for (int i = 0; i < ni; ++i) nudged[i] += jitter(i, options);
  std::vector<std::pair<Point, int>> pts;
  pts.reserve(surface.size() + interior.size() + out.exterior_poles.size());
  for (int i = 0; i < nb; ++i) pts.push_back({to_point(surface[i]), i});
  for (int i = 0; i < ni; ++i) pts.push_back({to_point(nudged[i]), nb + i});
  for (std::size_t i = 0; i < out.exterior_poles.size(); ++i)
    pts.push_back({to_point(out.exterior_poles[i]), -1});  // −1 marks a pole
  Delaunay dt = triangulate(pts, progress);
  progress.check_cancelled();

  std::vector<Delaunay::Vertex_handle> handle(std::size_t(nb + ni));
  for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v)
    if (v->info() >= 0) handle[v->info()] = v;

  // Rules 1 and 2 select the tets; where the result pinches (the boundary is not a disc around
  // a sample), that sample is deleted from the triangulation and the selection redone.
  for (int pass = 0;; ++pass) {
    progress(pass == 0 ? "pole removal" : "pinch removal", 0.7);
    out.delaunay_tets = out.removed_by_poles = 0;
    std::vector<Delaunay::Cell_handle> outside;
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
      ++out.delaunay_tets;
      CellInfo& info = c->info();
      if (info.test == CellTest::untested) {
        info.test = CellTest::inside;
        for (int k = 0; k < 4; ++k)
          if (c->vertex(k)->info() < 0) info.test = CellTest::pole;
        if (info.test == CellTest::inside && options.remove_outside_tets &&
            centroid_outside(c, occupancy, options))
          info.test = CellTest::outside;
      }
      info.fate = info.test == CellTest::pole      ? pole_cell
                  : info.test == CellTest::outside ? outside_cell
                                                   : kept_cell;
      if (info.fate == pole_cell) ++out.removed_by_poles;
      if (info.fate == outside_cell) outside.push_back(c);
    }
    if (options.remove_outside_tets)
      for (const Vec3& p : options.outside_points) {
        const Delaunay::Cell_handle c = dt.locate(to_point(p));
        if (dt.is_infinite(c) || c->info().fate != kept_cell) continue;
        c->info().fate = outside_cell;
        outside.push_back(c);
      }
    restore_enclosed(dt, outside);
    if (!options.repair_manifold || pass >= options.max_pinch_passes) break;
    // The boundary straight from the cells' adjacency (no tet list to sort each pass); the
    // pinched samples come out in index order, so their removal order is deterministic.
    const std::vector<std::int32_t> pinched =
        pinched_vertices(std::size_t(nb + ni), kept_boundary(dt));
    if (pinched.empty()) break;
    for (std::int32_t v : pinched) {
      dt.remove(handle[v]);
      out.pinched_samples.push_back(v < nb ? surface[v] : nudged[v - nb]);
    }
  }
  std::vector<Tet> kept;  // indices into B ∪ I
  out.removed_outside.clear();
  out.removed_by_centroid = 0;
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    if (c->info().fate == pole_cell) continue;
    std::array<Vec3, 4> corners;
    Tet t;
    for (int k = 0; k < 4; ++k) {
      t[k] = c->vertex(k)->info();
      corners[k] = to_vec(c->vertex(k)->point());
    }
    if (c->info().fate == outside_cell) {
      ++out.removed_by_centroid;
      out.removed_outside.push_back(corners);
    } else {
      kept.push_back(t);
    }
  }
  // CGAL's vertex removal orders its work by handle address, which varies from run to run;
  // a canonical order keeps the repair step (order-dependent) deterministic.
  for (Tet& t : kept) t = canonical(t);
  std::sort(kept.begin(), kept.end());

  progress("manifold repair", 0.9);
  std::vector<Vec3> points(surface);
  points.insert(points.end(), nudged.begin(), nudged.end());
  if (options.repair_manifold)
    out.repair = repair_boundary_manifold(points, kept, &out.removed_by_repair);
  out.removed_small_components =
      remove_small_tet_components(points, kept, options.min_component_fraction, &out.removed_by_repair);

  // Keep only referenced samples, in input order (B first, then I), for a deterministic mesh.
  std::vector<int> new_index(std::size_t(nb + ni), -1);
  for (const Tet& t : kept)
    for (int v : t) new_index[v] = 0;
  for (int v = 0; v < nb + ni; ++v) {
    if (new_index[v] < 0) {
      ++out.unused_samples;
      continue;
    }
    new_index[v] = int(out.mesh.vertices.size());
    out.mesh.vertices.push_back(points[v]);
    out.vertex_source.push_back(v);
  }
  out.mesh.tets.reserve(kept.size());
  for (const Tet& t : kept)
    out.mesh.tets.push_back(canonical({new_index[t[0]], new_index[t[1]], new_index[t[2]], new_index[t[3]]}));
  std::sort(out.mesh.tets.begin(), out.mesh.tets.end());
  progress("mesh", 1.0);
  return out;
}

}  // namespace cvt
