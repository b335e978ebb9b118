#include "meshing/mesh_generation.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <numeric>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_lock_grid_3.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/property_map.h>
#include <CGAL/spatial_sort.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include "base/errors.h"
#include "meshing/manifold_repair.h"

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
  signed char settled = -1;     // its fate when the last pass tested the pinches; −1 for a new cell
  CellTest test = CellTest::untested;
  signed char flat = -1;        // is_flat_tet of its corners: −1 not yet known, 0 no, 1 yes
  std::int32_t component = -1;  // kept cells: their face-connected group, when mesh() needs it
};
using CellBase = CGAL::Triangulation_cell_base_with_info_3<
    CellInfo, Kernel, CGAL::Delaunay_triangulation_cell_base_3<Kernel>>;
// Delaunay(B ∪ I ∪ EP) is built on every core (CGAL's concurrent triangulation, with a lock
// grid while it is built); Delaunay(B) for the poles is small and stays sequential.
using DataStructure =
    CGAL::Triangulation_data_structure_3<VertexBase, CellBase, CGAL::Parallel_tag>;
using LockGrid = CGAL::Spatial_lock_grid_3<CGAL::Tag_priority_blocking>;
using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, DataStructure, CGAL::Default, LockGrid>;
using SampleDelaunay = CGAL::Delaunay_triangulation_3<
    Kernel, CGAL::Triangulation_data_structure_3<
                VertexBase, CGAL::Delaunay_triangulation_cell_base_3<Kernel>>>;
using Point = Kernel::Point_3;

enum CellFate : int { kept_cell, pole_cell, outside_cell, flat_cell };
// dt's vertex info for an exterior pole: below pole_outside_below, or a slit pole (see
// MeshGenerationOptions::pole_outside_below).
constexpr int kPole = -1, kSlitPole = -2;

Point to_point(const Vec3& v) { return {v.x, v.y, v.z}; }
Vec3 to_vec(const Point& p) { return {p.x(), p.y(), p.z()}; }

std::vector<std::size_t> spatial_order(const std::vector<Point>& p) {
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  using SortTraits =
      CGAL::Spatial_sort_traits_adapter_3<Kernel, CGAL::Pointer_property_map<Point>::const_type>;
  CGAL::spatial_sort(order.begin(), order.end(), SortTraits(CGAL::make_property_map(p), Kernel()));
  return order;
}

// Inserts the points into dt (empty), in spatial order, on every core: each thread from its
// last vertex, locking the grid cells of what it changes, and again on a conflict. Lock cells
// span `box` (points outside fall into its border cells). The result is unique up to
// cospherical degeneracies, which CGAL resolves by symbolic perturbation, whatever the order.
// Infos are set afterwards: a point equal to an earlier one (in input order) shares its vertex,
// which keeps the earlier info. handles receives each point's vertex.
void insert_points(Delaunay& dt, const std::vector<std::pair<Point, int>>& points,
                   const CGAL::Bbox_3& box, const Progress& progress,
                   std::vector<Delaunay::Vertex_handle>& handles) {
  std::vector<Point> p;
  p.reserve(points.size());
  for (const auto& [point, info] : points) p.push_back(point);
  const std::vector<std::size_t> order = spatial_order(p);
  handles.assign(points.size(), Delaunay::Vertex_handle());
  Delaunay::Vertex_handle hint;
  // A few points first, sequentially, so the threads start from a 3D triangulation (as CGAL's
  // own parallel range insertion does); all of them with one thread.
  const bool parallel =
      std::min<std::size_t>(tbb::this_task_arena::max_concurrency(),
                            tbb::global_control::active_value(
                                tbb::global_control::max_allowed_parallelism)) > 1;
  std::size_t n = 0;
  for (; n < order.size() && (!parallel || n < 100 || dt.dimension() < 3); ++n) {
    if (n % 4096 == 0) progress.check_cancelled();
    handles[order[n]] = hint = dt.insert(p[order[n]], hint);
  }
  if (n < order.size()) {
    LockGrid lock(box, 50);
    dt.set_lock_data_structure(&lock);
    tbb::enumerable_thread_specific<Delaunay::Vertex_handle> hints(hint);
    try {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(n, order.size()), [&](const auto& r) {
        progress.check_cancelled();
        Delaunay::Vertex_handle& h = hints.local();
        for (std::size_t m = r.begin(); m != r.end(); ++m) {
          const Point& q = p[order[m]];
          for (bool done = false; !done;) {
            if (dt.try_lock_vertex(h) && dt.try_lock_point(q)) {
              const Delaunay::Vertex_handle v = dt.insert(q, h, &done);
              if (done) handles[order[m]] = h = v;
            }
            dt.unlock_all_elements();
          }
        }
      });
    } catch (...) {
      dt.set_lock_data_structure(nullptr);
      throw;
    }
    dt.set_lock_data_structure(nullptr);
  }
  std::unordered_set<const void*> named;
  named.reserve(points.size());
  for (std::size_t m = 0; m < points.size(); ++m)
    if (named.insert(&*handles[m]).second) handles[m]->info() = points[m].second;
}

// Delaunay(B) with each vertex's index in B, sequentially.
SampleDelaunay triangulate(const std::vector<Point>& points, const Progress& progress) {
  SampleDelaunay dt;
  const std::vector<std::size_t> order = spatial_order(points);
  SampleDelaunay::Vertex_handle hint;
  for (std::size_t n = 0; n < order.size(); ++n) {
    if (n % 4096 == 0) progress.check_cancelled();
    const std::size_t before = dt.number_of_vertices();
    hint = dt.insert(points[order[n]], hint);
    if (dt.number_of_vertices() > before) hint->info() = int(order[n]);
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
  // Summed in sample order, so the rounding does not depend on how the cell lists its corners.
  std::array<Delaunay::Vertex_handle, 4> v{c->vertex(0), c->vertex(1), c->vertex(2), c->vertex(3)};
  std::sort(v.begin(), v.end(), [](auto a, auto b) { return a->info() < b->info(); });
  std::array<Vec3, 4> p;
  Vec3 centroid{0, 0, 0};
  for (int k = 0; k < 4; ++k) centroid += p[k] = to_vec(v[k]->point());
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

std::vector<Delaunay::Cell_handle> finite_cells(const Delaunay& dt) {
  std::vector<Delaunay::Cell_handle> cells;
  cells.reserve(dt.number_of_finite_cells());
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) cells.push_back(c);
  return cells;
}

// Faces between kept cells and the rest (removed cells or the hull), as sample indices, in the
// order of `cells` (every finite cell; chunks in parallel, then joined in order).
std::vector<Triangle> kept_boundary(const Delaunay& dt, const std::vector<Delaunay::Cell_handle>& cells) {
  constexpr std::size_t kChunk = 8192;
  std::vector<std::vector<Triangle>> chunks((cells.size() + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t(0), chunks.size(), [&](std::size_t n) {
    for (std::size_t i = n * kChunk; i < std::min(cells.size(), (n + 1) * kChunk); ++i) {
      const Delaunay::Cell_handle c = cells[i];
      if (c->info().fate != kept_cell) continue;
      for (int k = 0; k < 4; ++k) {
        const Delaunay::Cell_handle nb = c->neighbor(k);
        if (!dt.is_infinite(nb) && nb->info().fate == kept_cell) continue;
        chunks[n].push_back({c->vertex((k + 1) & 3)->info(), c->vertex((k + 2) & 3)->info(),
                             c->vertex((k + 3) & 3)->info()});
      }
    }
  });
  std::vector<Triangle> faces;
  for (const auto& chunk : chunks) faces.insert(faces.end(), chunk.begin(), chunk.end());
  return faces;
}

// Rules 1 and 2 alone, for cells not tested yet (in parallel: each writes only its own info).
void test_cells(const std::vector<Delaunay::Cell_handle>& cells, const OccupancyFunction& occupancy,
                const MeshGenerationOptions& options) {
  tbb::parallel_for(std::size_t(0), cells.size(), [&](std::size_t i) {
    const Delaunay::Cell_handle c = cells[i];
    CellInfo& info = c->info();
    info.test = CellTest::inside;
    for (int k = 0; k < 4; ++k)
      if (c->vertex(k)->info() < 0) info.test = CellTest::pole;
    if (info.test == CellTest::inside && options.remove_outside_tets &&
        centroid_outside(c, occupancy, options))
      info.test = CellTest::outside;
  });
}

// Whether the boundary of the kept cells pinches at v: its link there, the far edges of the
// boundary faces around v, is not one cycle. It depends only on the cells around v, so after a
// pass only the vertices of cells that are new or changed fate need the test again.
bool pinched_at(const Delaunay& dt, Delaunay::Vertex_handle v,
                std::vector<Delaunay::Cell_handle>& cells,
                std::vector<std::pair<std::int32_t, std::int32_t>>& link) {
  cells.clear();
  link.clear();
  dt.finite_incident_cells(v, std::back_inserter(cells));
  for (const Delaunay::Cell_handle c : cells) {
    if (c->info().fate != kept_cell) continue;
    const int i = c->index(v);
    for (int k = 0; k < 4; ++k) {
      if (k == i) continue;
      const Delaunay::Cell_handle n = c->neighbor(k);
      if (!dt.is_infinite(n) && n->info().fate == kept_cell) continue;
      int far[2], m = 0;
      for (int j = 0; j < 4; ++j)
        if (j != i && j != k) far[m++] = c->vertex(j)->info();
      link.push_back({far[0], far[1]});
    }
  }
  return link_is_pinched(link);
}

// Rule 3, last part: kept cells on the boundary that are flat (coplanar samples make
// zero-volume slivers) go, and so do the flat cells that exposes, so the boundary is not
// folded over them. Returns the cells that went, in the order they went. The first boundary
// cells are found in parallel over `cells` (every finite cell), in its order.
std::vector<Delaunay::Cell_handle> peel_flat_boundary_cells(
    const Delaunay& dt, const std::vector<Delaunay::Cell_handle>& cells,
    const std::vector<Vec3>& points) {
  const auto on_boundary = [&](Delaunay::Cell_handle c) {
    for (int k = 0; k < 4; ++k) {
      const Delaunay::Cell_handle n = c->neighbor(k);
      if (dt.is_infinite(n) || n->info().fate != kept_cell) return true;
    }
    return false;
  };
  // Writes only the cell's own cache, so it may run on several cells at once.
  const auto flat = [&](Delaunay::Cell_handle c) {
    if (c->info().flat < 0) {
      Tet t;
      for (int k = 0; k < 4; ++k) t[k] = c->vertex(k)->info();
      c->info().flat = is_flat_tet(points, canonical(t));
    }
    return c->info().flat == 1;
  };
  constexpr std::size_t kChunk = 8192;
  std::vector<std::vector<Delaunay::Cell_handle>> found((cells.size() + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t(0), found.size(), [&](std::size_t n) {
    for (std::size_t i = n * kChunk; i < std::min(cells.size(), (n + 1) * kChunk); ++i) {
      const Delaunay::Cell_handle c = cells[i];
      if (c->info().fate == kept_cell && on_boundary(c) && flat(c)) found[n].push_back(c);
    }
  });
  std::vector<Delaunay::Cell_handle> stack, peeled;
  for (const auto& chunk : found) stack.insert(stack.end(), chunk.begin(), chunk.end());
  while (!stack.empty()) {
    const Delaunay::Cell_handle c = stack.back();
    stack.pop_back();
    if (c->info().fate != kept_cell) continue;
    c->info().fate = flat_cell;
    peeled.push_back(c);
    for (int k = 0; k < 4; ++k) {
      const Delaunay::Cell_handle n = c->neighbor(k);
      if (!dt.is_infinite(n) && n->info().fate == kept_cell && flat(n)) stack.push_back(n);
    }
  }
  return peeled;
}

// The samples among `around` (vertices of dt) whose boundary link pinches, in index order.
std::vector<std::int32_t> pinched_among(const Delaunay& dt,
                                        std::vector<Delaunay::Vertex_handle> around) {
  std::sort(around.begin(), around.end(), [](auto a, auto b) { return a->info() < b->info(); });
  around.erase(std::unique(around.begin(), around.end()), around.end());
  std::vector<std::int32_t> pinched;
  std::vector<Delaunay::Cell_handle> cells;  // pinched_at's work lists
  std::vector<std::pair<std::int32_t, std::int32_t>> link;
  for (const Delaunay::Vertex_handle v : around)
    if (v->info() >= 0 && pinched_at(dt, v, cells, link)) pinched.push_back(v->info());
  return pinched;
}

// What the poles of hull samples need: B's centroid (behind every hull facet) and a distance
// far outside B.
struct PoleFrame {
  Vec3 centroid{0, 0, 0};
  double far = 0;
};

PoleFrame pole_frame(const std::vector<Vec3>& surface) {
  PoleFrame frame;
  for (const Vec3& p : surface) frame.centroid += p;
  frame.centroid = frame.centroid / double(surface.size());
  frame.far = 4.0 * bounding_diagonal(surface);
  return frame;
}

// Appends the poles of the sample at v of Delaunay(B) (paper III-F): the farthest Voronoi
// vertex, and the farthest on the opposite side; for a sample on the convex hull, a point far
// out along the outward normal.
void poles_of(const SampleDelaunay& dt, SampleDelaunay::Vertex_handle v, const PoleFrame& frame,
              std::vector<SampleDelaunay::Cell_handle>& cells, std::vector<Vec3>& poles) {
  const Vec3 s = to_vec(v->point());
  cells.clear();
  // The plain incident_cells marks the cells it visits: a race when threads walk one
  // triangulation (the poles of all samples are found in parallel).
  dt.incident_cells_threadsafe(v, std::back_inserter(cells));
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
      if (dot(n, a - frame.centroid) < 0) n = n * -1.0;
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
    if (len == 0) return;
    direction = outward / len;
    first = s + direction * frame.far;
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

}  // namespace

// What stage 5 keeps between rounds: Delaunay(B) for the poles, each sample's poles, and
// Delaunay(B ∪ I ∪ EP) with the cells' cached rule results.
struct DelaunayMesher::State {
  // near_surface: a slit pole taken out again because it carved a void.
  enum class PoleKind : unsigned char { interior, exterior, near_surface };
  struct Pole {
    Vec3 at;
    PoleKind kind;
    bool slit;                       // exterior with occupancy ≥ pole_outside_below
    Delaunay::Vertex_handle vertex;  // an exterior pole's vertex of dt (null if it is a sample)
  };

  OccupancyFunction occupancy;
  MeshGenerationOptions options;
  Progress progress;
  std::vector<Vec3> surface, interior;  // B, and I as inserted (nudged)
  SampleDelaunay samples_dt;            // Delaunay(B); vertex info: index in B
  PoleFrame frame;
  std::vector<std::vector<Pole>> poles;  // per sample of B
  Delaunay dt;                           // vertex info: index in B ∪ I, or kPole / kSlitPole
  std::vector<Delaunay::Vertex_handle> handle;  // per sample of B ∪ I; null once deleted
  std::unordered_map<const void*, int> pole_uses;  // samples whose exterior pole a vertex is
  std::vector<int> pinched;  // samples rule 3 deleted since the last refine (index in B ∪ I)
  bool pinch_free = false;   // the last mesh() ended with no vertex pinched

  std::vector<Pole> classify(const std::vector<Vec3>& at) const {
    std::vector<Pole> out;
    for (const Vec3& p : at) {
      const double o = occupancy(p);
      out.push_back({p, o >= options.inside_from ? PoleKind::interior : PoleKind::exterior,
                     o >= options.pole_outside_below, {}});
    }
    return out;
  }

  // Poles of B's sample at vertex v of samples_dt.
  std::vector<Pole> poles_at(SampleDelaunay::Vertex_handle v) const {
    std::vector<SampleDelaunay::Cell_handle> cells;
    std::vector<Vec3> at;
    poles_of(samples_dt, v, frame, cells, at);
    return classify(at);
  }

  // Slit poles (occupancy ≥ pole_outside_below) whose removed cells make a void: the removed
  // cells (poles' and centroid-removed) around them reach neither the hull nor a pole below
  // pole_outside_below. A flood from each slit pole over removed cells; a flood that meets
  // the outside marks what it crossed, so later floods stop there.
  std::vector<Delaunay::Vertex_handle> enclosed_slit_poles() const {
    std::vector<Delaunay::Vertex_handle> slit;
    for (auto v = dt.finite_vertices_begin(); v != dt.finite_vertices_end(); ++v)
      if (v->info() == kSlitPole) slit.push_back(v);
    std::vector<Delaunay::Vertex_handle> out;
    if (slit.empty()) return out;
    std::unordered_map<const void*, bool> open;  // flooded cells: whether they reach outside
    std::vector<Delaunay::Cell_handle> region, queue, around;
    for (const Delaunay::Vertex_handle v : slit) {
      around.clear();
      dt.incident_cells(v, std::back_inserter(around));
      if (open.count(&*around.front())) continue;  // an earlier flood crossed this pole
      region.clear();
      bool reaches_outside = false;
      for (const Delaunay::Cell_handle c : around) {
        const auto seen = open.emplace(&*c, false);
        if (seen.second) queue.push_back(c);
        else if (seen.first->second) reaches_outside = true;
      }
      while (!queue.empty() && !reaches_outside) {
        const Delaunay::Cell_handle c = queue.back();
        queue.pop_back();
        region.push_back(c);
        if (dt.is_infinite(c)) { reaches_outside = true; break; }
        for (int k = 0; k < 4 && !reaches_outside; ++k) {
          const Delaunay::Vertex_handle w = c->vertex(k);
          if (w->info() == kPole) reaches_outside = true;
        }
        for (int k = 0; k < 4 && !reaches_outside; ++k) {
          const Delaunay::Cell_handle n = c->neighbor(k);
          if (!dt.is_infinite(n) && n->info().fate == kept_cell) continue;
          const auto seen = open.emplace(&*n, false);
          if (seen.second) queue.push_back(n);
          else if (seen.first->second) reaches_outside = true;
        }
      }
      if (reaches_outside) {
        for (const Delaunay::Cell_handle c : queue) open[&*c] = true;  // met, not yet crossed
        queue.clear();
        for (const Delaunay::Cell_handle c : region) open[&*c] = true;
        for (const Delaunay::Cell_handle c : around) open[&*c] = true;
        continue;
      }
      for (const Delaunay::Cell_handle c : region)
        for (int k = 0; k < 4; ++k)
          if (c->vertex(k)->info() == kSlitPole) out.push_back(c->vertex(k));
    }
    std::sort(out.begin(), out.end(), [](auto a, auto b) { return a->point() < b->point(); });
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  // Takes the poles out of dt; their samples keep them as near-surface poles.
  void remove_poles(const std::vector<Delaunay::Vertex_handle>& gone) {
    std::unordered_map<const void*, bool> is_gone;
    for (const Delaunay::Vertex_handle v : gone) is_gone[&*v] = true;
    for (auto& sample : poles)
      for (Pole& pole : sample)
        if (pole.vertex != Delaunay::Vertex_handle() && is_gone.count(&*pole.vertex)) {
          pole.vertex = Delaunay::Vertex_handle();
          pole.kind = PoleKind::near_surface;
        }
    for (const Delaunay::Vertex_handle v : gone) {
      pole_uses.erase(&*v);
      dt.remove(v);
    }
  }

  // An exterior pole joins dt (or counts one more use of the vertex already there).
  void insert_pole(Pole& pole) {
    const std::size_t before = dt.number_of_vertices();
    const Delaunay::Vertex_handle v = dt.insert(to_point(pole.at));
    if (dt.number_of_vertices() > before) v->info() = pole.slit ? kSlitPole : kPole;
    if (v->info() >= 0) return;  // the point is a sample's: nothing to remove later
    pole.vertex = v;
    ++pole_uses[&*v];
  }
};

DelaunayMesher::DelaunayMesher(const std::vector<Vec3>& surface,
                               const std::vector<Vec3>& interior,
                               const OccupancyFunction& occupancy,
                               const MeshGenerationOptions& options, const Progress& progress)
    : s_(std::make_unique<State>()) {
  if (surface.size() < 4) throw InputError("mesh generation: fewer than 4 surface samples");
  State& s = *s_;
  s.occupancy = occupancy;
  s.options = options;
  s.progress = progress;
  s.surface = surface;
  s.interior = interior;
  for (std::size_t i = 0; i < interior.size(); ++i) s.interior[i] += jitter(int(i), options);

  // The poles first, from Delaunay(B); then Delaunay(B ∪ I ∪ EP) in one parallel build.
  progress("poles", 0.0);
  const int nb = int(surface.size()), ni = int(interior.size());
  std::vector<Point> b;
  b.reserve(surface.size());
  CGAL::Bbox_3 box;  // the lock grid's: the samples' (exterior poles reach far beyond)
  for (const Vec3& p : s.surface) box += (b.emplace_back(to_point(p))).bbox();
  for (const Vec3& p : s.interior) box += to_point(p).bbox();
  s.samples_dt = triangulate(b, progress);
  s.frame = pole_frame(surface);
  s.poles.resize(surface.size());
  std::vector<SampleDelaunay::Vertex_handle> vertices;
  vertices.reserve(s.samples_dt.number_of_vertices());
  for (auto v = s.samples_dt.finite_vertices_begin(); v != s.samples_dt.finite_vertices_end(); ++v)
    vertices.push_back(v);
  tbb::parallel_for(std::size_t(0), vertices.size(), [&](std::size_t n) {
    s.poles[vertices[n]->info()] = s.poles_at(vertices[n]);  // reads only Delaunay(B)
  });
  progress("Delaunay", 0.3);

  std::vector<std::pair<Point, int>> points;
  points.reserve(surface.size() + interior.size());
  for (int i = 0; i < nb; ++i) points.push_back({b[i], i});
  for (int i = 0; i < ni; ++i) points.push_back({to_point(s.interior[i]), nb + i});
  std::vector<State::Pole*> exterior;
  for (auto& sample : s.poles)
    for (State::Pole& pole : sample)
      if (pole.kind == State::PoleKind::exterior) {
        exterior.push_back(&pole);
        points.push_back({to_point(pole.at), pole.slit ? kSlitPole : kPole});
      }
  std::vector<Delaunay::Vertex_handle> handles;
  insert_points(s.dt, points, box, progress, handles);
  s.handle.assign(std::size_t(nb + ni), Delaunay::Vertex_handle());
  for (int i = 0; i < nb + ni; ++i)
    if (handles[i]->info() == i) s.handle[i] = handles[i];  // else a duplicate of an earlier one
  for (std::size_t k = 0; k < exterior.size(); ++k) {
    const Delaunay::Vertex_handle v = handles[std::size_t(nb + ni) + k];
    if (v->info() >= 0) continue;  // the point is a sample's: nothing to remove later
    exterior[k]->vertex = v;
    ++s.pole_uses[&*v];
  }
}

DelaunayMesher::~DelaunayMesher() = default;

void DelaunayMesher::refine(const std::vector<Vec3>& new_surface,
                            const std::vector<int>& dropped_interior,
                            const std::vector<Vec3>& outside_points) {
  State& s = *s_;
  const int nb = int(s.surface.size()), ni = int(s.interior.size()), na = int(new_surface.size());
  std::vector<char> drop(std::size_t(ni), 0);
  for (int d : dropped_interior) drop.at(std::size_t(d)) = 1;  // checked before any change
  s.progress("poles", 0.0);
  // 1. Delaunay(B) gains the new samples. Only samples whose Voronoi cell changed (the new
  // ones and their neighbours) can have new poles.
  for (int k = 0; k < na; ++k) {
    const std::size_t before = s.samples_dt.number_of_vertices();
    const SampleDelaunay::Vertex_handle v = s.samples_dt.insert(to_point(new_surface[k]));
    if (s.samples_dt.number_of_vertices() == before) continue;  // a duplicate: no new cell
    v->info() = nb + k;
  }
  s.surface.insert(s.surface.end(), new_surface.begin(), new_surface.end());
  s.poles.resize(std::size_t(nb + na));
  std::vector<SampleDelaunay::Vertex_handle> changed;
  for (auto v = s.samples_dt.finite_vertices_begin(); v != s.samples_dt.finite_vertices_end(); ++v)
    if (v->info() >= nb) {
      changed.push_back(v);
      s.samples_dt.finite_adjacent_vertices(v, std::back_inserter(changed));
    }
  std::sort(changed.begin(), changed.end(),
            [](auto a, auto b) { return a->info() < b->info(); });
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());

  // 2. Their exterior poles in dt are replaced: new ones in first, so a pole that stays (a
  // Voronoi vertex the change did not touch) is never removed and inserted again.
  std::vector<std::vector<State::Pole>> old(changed.size());
  for (std::size_t n = 0; n < changed.size(); ++n) {
    std::vector<State::Pole>& poles = s.poles[changed[n]->info()];
    old[n] = std::move(poles);
    poles = s.poles_at(changed[n]);
    for (State::Pole& pole : poles)
      if (pole.kind == State::PoleKind::exterior) s.insert_pole(pole);
  }
  for (const auto& poles : old)
    for (const State::Pole& pole : poles)
      if (pole.vertex != Delaunay::Vertex_handle()) {
        const auto uses = s.pole_uses.find(&*pole.vertex);
        assert(uses != s.pole_uses.end() && uses->second > 0);
        if (--uses->second > 0) continue;
        s.pole_uses.erase(uses);
        s.dt.remove(pole.vertex);
      }
  s.progress.check_cancelled();

  // 3. dt: B grows by the new samples, I loses the dropped ones; indices follow. Samples
  // rule 3 deleted come back, as the new samples may have resolved their pinch.
  s.progress("Delaunay", 0.3);
  for (int v : s.pinched) {
    if (v >= nb && drop[v - nb]) continue;
    const std::size_t before = s.dt.number_of_vertices();
    const Delaunay::Vertex_handle h = s.dt.insert(to_point(v < nb ? s.surface[v] : s.interior[v - nb]));
    if (s.dt.number_of_vertices() > before) s.handle[v] = h;
  }
  s.pinched.clear();
  std::vector<Delaunay::Vertex_handle> handle(s.handle.begin(), s.handle.begin() + nb);
  handle.resize(std::size_t(nb + na));  // the new samples' handles follow below
  std::vector<Vec3> interior;
  for (int i = 0; i < ni; ++i) {
    const Delaunay::Vertex_handle v = s.handle[std::size_t(nb + i)];
    if (drop[i]) {
      if (v != Delaunay::Vertex_handle()) s.dt.remove(v);
      continue;
    }
    interior.push_back(s.interior[i]);
    handle.push_back(v);
  }
  for (int k = 0; k < na; ++k) {
    const std::size_t before = s.dt.number_of_vertices();
    const Delaunay::Vertex_handle v = s.dt.insert(to_point(new_surface[k]));
    if (s.dt.number_of_vertices() > before) handle[std::size_t(nb + k)] = v;
  }
  for (std::size_t i = 0; i < handle.size(); ++i)
    if (handle[i] != Delaunay::Vertex_handle()) handle[i]->info() = int(i);
  s.handle = std::move(handle);
  s.interior = std::move(interior);
  s.options.outside_points.insert(s.options.outside_points.end(), outside_points.begin(),
                                  outside_points.end());
}

MeshGenerationResult DelaunayMesher::mesh() {
  State& s = *s_;
  const MeshGenerationOptions& options = s.options;
  const Progress& progress = s.progress;
  Delaunay& dt = s.dt;
  const int nb = int(s.surface.size()), ni = int(s.interior.size());
  MeshGenerationResult out;

  // Rules 1 and 2 select the tets; where the result pinches (the boundary is not a disc around
  // a sample), that sample is deleted from the triangulation and the selection redone.
  std::vector<Vec3> points(s.surface);
  points.insert(points.end(), s.interior.begin(), s.interior.end());
  bool pinch_free = false;
  for (int pass = 0;; ++pass) {
    progress(pass == 0 ? "pole removal" : "pinch removal", 0.7);
    out.delaunay_tets = out.removed_by_poles = 0;
    std::vector<Delaunay::Cell_handle> outside, changed;
    const auto settle_fate = [&](Delaunay::Cell_handle c) {
      CellInfo& info = c->info();
      info.fate = info.test == CellTest::pole      ? pole_cell
                  : info.test == CellTest::outside ? outside_cell
                                                   : kept_cell;
      if (info.fate == pole_cell) ++out.removed_by_poles;
      if (info.fate == outside_cell) outside.push_back(c);
      else if (info.fate != info.settled) changed.push_back(c);
    };
    // Cells not tested yet (all of them in the first mesh, a few new ones later) are tested
    // together, in parallel. The first pass also lists every cell, for its boundary.
    std::vector<Delaunay::Cell_handle> untested, cells;  // cells: pass 0 only
    if (pass == 0) cells.reserve(dt.number_of_finite_cells());
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
      ++out.delaunay_tets;
      if (pass == 0) cells.push_back(c);
      if (c->info().test == CellTest::untested) untested.push_back(c);
      else settle_fate(c);
    }
    test_cells(untested, s.occupancy, options);
    for (const Delaunay::Cell_handle c : untested) settle_fate(c);
    if (options.remove_outside_tets)
      for (const Vec3& p : options.outside_points) {
        const Delaunay::Cell_handle c = dt.locate(to_point(p));
        if (dt.is_infinite(c) || c->info().fate != kept_cell) continue;
        c->info().fate = outside_cell;
        outside.push_back(c);
      }
    restore_enclosed(dt, outside);
    {
      // Pinch removal can close a slit's mouth, so every pass looks for voids. A later pass
      // that goes on here leaves its cells unsettled: the next one retests more, not less.
      const std::vector<Delaunay::Vertex_handle> enclosed = s.enclosed_slit_poles();
      if (!enclosed.empty()) {
        s.remove_poles(enclosed);
        if (pass == 0) pass = -1;  // pass 0 again: it tests every vertex for pinches
        continue;
      }
    }
    out.repair.flat_removed = 0;
    if (!options.repair_manifold || pass >= options.max_pinch_passes) break;
    // The boundary straight from the cells' adjacency (no tet list to sort each pass); the
    // pinched samples come out in index order, so their removal order is deterministic.
    // Every fate now settles. Cells not listed kept theirs, and restore_enclosed touched only
    // outside ones.
    // The first pass of the first mesh tests every vertex; later ones only those around a
    // change, as every vertex pinched before was removed. (A refine's new cells cover every
    // vertex whose cells it changed, and a mesh that ended pinch-free had none pinched.)
    const bool test_all = pass == 0 && !s.pinch_free;
    std::vector<Delaunay::Vertex_handle> retest;
    for (const auto* list : {&changed, &outside})
      for (const Delaunay::Cell_handle c : *list) {
        if (c->info().fate == c->info().settled) continue;
        c->info().settled = static_cast<signed char>(c->info().fate);
        if (test_all) continue;
        for (int k = 0; k < 4; ++k)
          if (c->vertex(k)->info() >= 0) retest.push_back(c->vertex(k));
      }
    std::vector<std::int32_t> pinched;
    if (test_all) {
      pinched = pinched_vertices(std::size_t(nb + ni), kept_boundary(dt, cells));
    } else {
      pinched = pinched_among(dt, std::move(retest));
    }
    if (pinched.empty()) {
      // Flat cells are peeled from the boundary once it no longer pinches; if that makes a
      // pinch, its samples go too and the passes go on. Only the peeled cells' corners can
      // pinch now.
      const std::vector<Delaunay::Cell_handle> peeled =
          peel_flat_boundary_cells(dt, pass == 0 ? cells : finite_cells(dt), points);
      out.repair.flat_removed = peeled.size();
      std::vector<Delaunay::Vertex_handle> corners;
      for (const Delaunay::Cell_handle c : peeled)
        for (int k = 0; k < 4; ++k) corners.push_back(c->vertex(k));
      pinched = pinched_among(dt, std::move(corners));
    }
    if (pinched.empty()) {
      pinch_free = true;
      break;
    }
    for (std::int32_t v : pinched) {
      dt.remove(s.handle[v]);
      s.handle[v] = Delaunay::Vertex_handle();
      s.pinched.push_back(v);
      out.pinched_samples.push_back(v < nb ? s.surface[v] : s.interior[v - nb]);
    }
  }
  s.pinch_free = pinch_free;
  // (After the passes: slit poles that carved a void are near-surface ones now.)
  for (const auto& sample : s.poles)
    for (const State::Pole& pole : sample) {
      if (pole.kind == State::PoleKind::exterior) out.exterior_poles.push_back(pole.at);
      if (pole.kind == State::PoleKind::interior) out.interior_poles.push_back(pole.at);
      if (pole.kind == State::PoleKind::near_surface) ++out.near_surface_poles;
    }
  // Without pinches every boundary link is one cycle, so every boundary edge has two faces:
  // peeling (rule 3's fallback) could only remove flat tets on the boundary, and those went
  // in the last pass. So it is skipped, and rule 4's groups come from the cells' adjacency,
  // not a face sort.
  const bool peel = options.repair_manifold && !pinch_free;
  // Rule 4's groups: the kept cells' face-connected components, numbered in cell order. The
  // walk runs on one core while the other lists and sorts the kept tets.
  const auto number_groups = [&] {
    std::int32_t groups = 0;
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c)
      if (c->info().fate == kept_cell) c->info().component = -1;
    std::vector<Delaunay::Cell_handle> queue;
    for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end() && !peel; ++c) {
      if (c->info().fate != kept_cell || c->info().component >= 0) continue;
      c->info().component = groups;
      queue.assign(1, c);
      while (!queue.empty()) {
        const Delaunay::Cell_handle q = queue.back();
        queue.pop_back();
        for (int k = 0; k < 4; ++k) {
          const Delaunay::Cell_handle n = q->neighbor(k);
          if (!dt.is_infinite(n) && n->info().fate == kept_cell && n->info().component < 0) {
            n->info().component = groups;
            queue.push_back(n);
          }
        }
      }
      ++groups;
    }
  };
  tbb::task_group grouping;
  grouping.run(number_groups);
  std::vector<std::pair<Tet, Delaunay::Cell_handle>> kept;  // indices into B ∪ I
  // The samples on a kept cell's face whose other side is not kept. Rule 4 keeps or drops
  // whole face-connected groups, and a sample of a dropped group that a kept one also uses
  // lies on a face between a kept cell and another around it, so this stays right for every
  // sample the mesh keeps. Peeling changes faces anywhere: then the mesh's faces decide.
  std::vector<std::uint8_t> sample_on_boundary(peel ? 0 : std::size_t(nb + ni), 0);
  // Cells in chunks on all cores, joined in cell order.
  struct Chunk {
    std::vector<std::pair<Tet, Delaunay::Cell_handle>> kept;
    std::vector<std::array<Vec3, 4>> outside, flat;
    std::vector<std::uint8_t> boundary_faces;  // per kept cell: its faces with no kept cell behind
  };
  const std::vector<Delaunay::Cell_handle> all_cells = finite_cells(dt);
  constexpr std::size_t kChunk = 8192;
  std::vector<Chunk> chunks((all_cells.size() + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t(0), chunks.size(), [&](std::size_t n) {
    Chunk& chunk = chunks[n];
    for (std::size_t i = n * kChunk; i < std::min(all_cells.size(), (n + 1) * kChunk); ++i) {
      const Delaunay::Cell_handle c = all_cells[i];
      if (c->info().fate == pole_cell) continue;
      std::array<Vec3, 4> corners;
      Tet t;
      for (int k = 0; k < 4; ++k) {
        t[k] = c->vertex(k)->info();
        corners[k] = to_vec(c->vertex(k)->point());
      }
      std::uint8_t faces = 0;
      if (!peel && c->info().fate == kept_cell)
        for (int k = 0; k < 4; ++k) {
          const Delaunay::Cell_handle nb_cell = c->neighbor(k);
          if (!dt.is_infinite(nb_cell) && nb_cell->info().fate == kept_cell) continue;
          ++faces;
          for (int j = 0; j < 4; ++j)  // every writer stores the same 1
            if (j != k)
              std::atomic_ref(sample_on_boundary[std::size_t(t[j])])
                  .store(1, std::memory_order_relaxed);
        }
      if (c->info().fate == outside_cell) chunk.outside.push_back(corners);
      else if (c->info().fate == flat_cell) chunk.flat.push_back(corners);
      else {
        chunk.kept.push_back({canonical(t), c});
        chunk.boundary_faces.push_back(faces);
      }
    }
  });
  std::size_t kept_count = 0;
  for (const Chunk& chunk : chunks) kept_count += chunk.kept.size();
  kept.reserve(kept_count);
  std::vector<std::uint8_t> boundary_faces;  // per kept tet (without peeling: in kept's order)
  boundary_faces.reserve(peel ? 0 : kept_count);
  for (Chunk& chunk : chunks) {
    out.removed_by_centroid += chunk.outside.size();
    out.removed_outside.insert(out.removed_outside.end(), chunk.outside.begin(),
                               chunk.outside.end());
    out.removed_by_repair.insert(out.removed_by_repair.end(), chunk.flat.begin(), chunk.flat.end());
    kept.insert(kept.end(), chunk.kept.begin(), chunk.kept.end());
    boundary_faces.insert(boundary_faces.end(), chunk.boundary_faces.begin(),
                          chunk.boundary_faces.end());
    chunk = Chunk();
  }
  // CGAL's vertex removal orders its work by handle address, which varies from run to run;
  // a canonical order keeps the peeling repair (order-dependent) deterministic. No two cells
  // have the same corners, so the order is total. Without it, only the small components'
  // removal follows, which is order-free, and the tets are sorted at the end.
  if (peel)
    tbb::parallel_sort(kept.begin(), kept.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
  grouping.wait();
  std::vector<Tet> tets(kept.size());
  std::vector<std::int32_t> group(kept.size());
  for (std::size_t t = 0; t < kept.size(); ++t) {
    tets[t] = kept[t].first;
    group[t] = kept[t].second->info().component;
  }
  kept = {};

  progress("manifold repair", 0.9);
  if (peel) {
    const std::size_t flat = out.repair.flat_removed;
    out.repair = repair_boundary_manifold(points, tets, &out.removed_by_repair);
    out.repair.flat_removed += flat;
    out.removed_small_components = remove_small_tet_components(
        points, tets, options.min_component_fraction, &out.removed_by_repair);
  } else {
    out.repair.manifold = options.repair_manifold;  // what a peeling pass would have found
    const std::vector<Tet> all = tets;
    out.removed_small_components = remove_small_tet_components(
        points, tets, group, options.min_component_fraction, &out.removed_by_repair);
    // The removed groups' boundary faces go with them (the kept tets keep their order).
    for (std::size_t t = 0, u = 0; t < all.size(); ++t)
      if (u < tets.size() && tets[u] == all[t]) ++u;
      else boundary_faces[t] = 0;
  }

  // Keep only referenced samples, in input order (B first, then I), for a deterministic mesh.
  std::vector<int> new_index(std::size_t(nb + ni), -1);
  for (const Tet& t : tets)
    for (int v : t) new_index[v] = 0;
  for (int v = 0; v < nb + ni; ++v) {
    if (new_index[v] < 0) {
      ++out.unused_samples;
      continue;
    }
    new_index[v] = int(out.mesh.vertices.size());
    out.mesh.vertices.push_back(points[v]);
    out.vertex_source.push_back(v);
    if (!peel) out.on_boundary.push_back(sample_on_boundary[std::size_t(v)]);
  }
  out.mesh.tets.reserve(tets.size());
  for (const Tet& t : tets)
    out.mesh.tets.push_back(canonical({new_index[t[0]], new_index[t[1]], new_index[t[2]], new_index[t[3]]}));
  tbb::parallel_sort(out.mesh.tets.begin(), out.mesh.tets.end());  // distinct tets: a total order
  long long faces = std::accumulate(boundary_faces.begin(), boundary_faces.end(), 0LL);
  if (peel) {
    const std::vector<Triangle> boundary = boundary_triangles(out.mesh);
    out.on_boundary.assign(out.mesh.vertices.size(), 0);
    for (const Triangle& f : boundary)
      for (std::int32_t v : f) out.on_boundary[std::size_t(v)] = 1;
    faces = (long long)boundary.size();
  }
  // The boundary is closed (every edge in two faces): its Euler characteristic is V − F/2.
  out.boundary_euler = std::count(out.on_boundary.begin(), out.on_boundary.end(), 1) - faces / 2;
  progress("mesh", 1.0);
  return out;
}

MeshGenerationResult build_delaunay_mesh(const std::vector<Vec3>& surface,
                                         const std::vector<Vec3>& interior,
                                         const OccupancyFunction& occupancy,
                                         const MeshGenerationOptions& options,
                                         const Progress& progress) {
  return DelaunayMesher(surface, interior, occupancy, options, progress).mesh();
}

}  // namespace cvt
