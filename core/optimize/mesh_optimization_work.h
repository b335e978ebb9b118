// Internal to stage 6 (mesh_optimization*.cpp): the mutable tet mesh the optimiser works on —
// tets in slots (a dead slot is reused), the live tets around each vertex, a cached quality per
// tet — plus the quality every decision is made with and the boundary surface constraint.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "base/progress.h"
#include "base/tet_mesh.h"
#include "base/volume.h"

namespace cvt::opt {

// The smallest sine of the six dihedral angles (regular tet 0.9428): small for every kind of
// flat tet (sliver, cap, wedge: dihedral angles near 0° or 180°), no trigonometry needed
// (sin θ_e = 3 V ℓ_e / (2 A_i A_j)); −1 for an inverted or zero-volume tet.
double min_sine(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// The quality every decision is made with: the smallest of four figures, each divided by the
// value where a tet turns bad, so a tet is bad exactly when its quality is below 1:
//   min sine of the dihedral angles / sin(target angle)  (slivers, caps, wedges: dihedral angles
//                                                         near 0° or 180°)
//   V / r_mc³ / v_over_rmc3, and the gradient-error and condition-number measures over their
//   bounds (Table I's "bad" bins: needles and spindles too, which have fine dihedral angles).
// −1 for an inverted or zero-volume tet.
struct QualityScale {
  double sine = 0.342;        // sin 20°
  double v_over_rmc3 = 0.01;  // Table I bin edges of the three measures
  double gradient_error = 0.05;
  double condition_number = 0.1;
};
// With `floor`: when the quality is at most floor, some value ≤ floor is returned early.
double tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                   const QualityScale& scale,
                   double floor = -std::numeric_limits<double>::infinity());

// No operation makes a tet flatter than this quality (nearly zero volume).
inline constexpr double kMinValidQuality = 1e-6;

// A tet is dead when t[0] < 0.
inline bool is_dead(const Tet& t) {
  return t[0] < 0;
}

// A tet mesh open to local changes. Vertices keep their slots: inserted ones are appended, and
// a removed one is left without tets (to_mesh drops it).
class WorkMesh {
 public:
  WorkMesh(const TetMesh& mesh, const QualityScale& scale);
  // Live tets in slot order, vertices without tets dropped; `origin` (if given) receives, for
  // each output vertex, its slot here (input vertices first, then inserted ones).
  TetMesh to_mesh(std::vector<std::int32_t>* origin = nullptr) const;

  std::size_t vertex_count() const { return pos.size(); }
  std::size_t live_tets() const { return tets.size() - free_slots.size(); }
  double tet_quality(const Tet& t) const {
    return opt::tet_quality(pos[t[0]], pos[t[1]], pos[t[2]], pos[t[3]], scale);
  }
  double tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                     double floor = -std::numeric_limits<double>::infinity()) const {
    return opt::tet_quality(a, b, c, d, scale, floor);
  }
  // Adds a tet (positively oriented) and returns its slot; its quality must be given.
  std::int32_t add_tet(const Tet& t, std::int32_t label, double q);
  void remove_tet(std::int32_t slot);
  // Live tets using every vertex of `vs` (the first `count` entries).
  void tets_with(const std::int32_t* vs, int count, std::vector<std::int32_t>& out) const;
  // The ring of tets around edge (a, b): (a, b, ring[i], ring[i+1]) is the positively
  // oriented tet ring_tets[i]. Closed (an interior edge): ring.size() == ring_tets.size() and
  // the last tet wraps to ring[0]. Open (a boundary edge): ring has one vertex more, and the
  // faces (a, b, ring.front()) and (a, b, ring.back()) are on the boundary. None: no such edge,
  // or the tets around it are not one fan.
  enum class Ring { none, closed, open };
  Ring edge_ring(std::int32_t a, std::int32_t b, std::vector<std::int32_t>& ring,
                 std::vector<std::int32_t>& ring_tets) const;
  // Whether edge (a, b) exists (used by a live tet).
  bool has_edge(std::int32_t a, std::int32_t b) const;
  // Whether edge (a, b) lies on the boundary (some face through it is used by one tet only).
  bool is_boundary_edge(std::int32_t a, std::int32_t b) const;

  std::vector<Vec3> pos;             // vertex positions (world, mm)
  std::vector<Tet> tets;             // slots, positively oriented
  std::vector<std::int32_t> labels;  // per slot
  QualityScale scale;
  std::vector<double> quality;                         // tet_quality per slot
  std::vector<std::vector<std::int32_t>> vertex_tets;  // live slots around each vertex
  std::vector<char> on_boundary;                       // vertex lies on a boundary face
  std::vector<char> on_surface;  // boundary vertex on the level set: may slide along it (set by
                                 // the optimiser; empty = none)
  std::vector<std::int32_t> free_slots;  // dead slots, reused last-in first
  // The running pass's cancel flag (may be null): the phases check it between chunks of work,
  // where the mesh is whole, so a cancel stops within a fraction of a second.
  const Progress* progress = nullptr;
  void check_cancelled() const {
    if (progress) progress->check_cancelled();
  }

  // Change tracking, so that work which failed is not repeated on an unchanged neighbourhood:
  // a vertex's stamp is the clock at the last change of a tet around it (added, removed, or a
  // vertex of it moved).
  std::uint64_t clock = 1;
  std::vector<std::uint64_t> vertex_stamp;   // per vertex
  std::vector<std::uint64_t> flip_failed;    // per slot: clock when no flip improved it (0: never)
  std::vector<std::uint64_t> insert_failed;  // per slot: clock when no insertion improved it
  std::vector<std::uint64_t> move_failed;    // per vertex: clock when no move improved its star
  // Records that vertex v moved: every tet around it changed.
  void touch_star(std::int32_t v) {
    ++clock;
    for (std::int32_t t : vertex_tets[v])
      for (std::int32_t w : tets[t]) vertex_stamp[w] = clock;
  }
  // Whether no tet around any vertex of the given (live) tets changed after clock `stamp`: then
  // those tets are exactly as they were.
  bool unchanged_since(const std::vector<std::int32_t>& slots, std::uint64_t stamp) const {
    for (std::int32_t t : slots)
      for (std::int32_t v : tets[t])
        if (v < 0 || vertex_stamp[v] > stamp) return false;
    return true;
  }
  // Whether anything around tet t changed after clock `stamp`.
  bool changed_since(std::int32_t t, std::uint64_t stamp) const {
    const Tet& tet = tets[t];
    return std::max({vertex_stamp[tet[0]], vertex_stamp[tet[1]], vertex_stamp[tet[2]],
                     vertex_stamp[tet[3]]}) > stamp;
  }
};

// The boundary faces (used by one live tet, outward), in slot order.
std::vector<Triangle> boundary_faces(const WorkMesh& m);

// The tet (a, b, c, d) rearranged as an even permutation of `t` that starts with a, b.
Tet rotate_to_edge(const Tet& t, std::int32_t a, std::int32_t b);

// The boundary surface as the `level` set of a sampled field (the smoothed indicator, 0.5):
// projection onto it, its normal, and the distance of a point to it.
class LevelSetSurface {
 public:
  LevelSetSurface(const Volume<float>& field, float level) : field_(&field), level_(level) {}
  // Moves `world` onto the level set (Newton along the gradient); false when that does not
  // converge within max_move_mm (the point is then left as it was).
  bool project(Vec3& world, double max_move_mm) const;
  Vec3 unit_normal(const Vec3& world) const;  // world frame, pointing to increasing field
  // Distance (mm) from `world` to the level set: |f − level| / |∇f| near it, else the length
  // of its projection; capped at 20 × the smallest voxel spacing (where the field is flat).
  double distance(const Vec3& world) const;
  // Signed distance (mm; outside positive) to first order, (level − f) / |∇f|: accurate within
  // about a voxel of the level set; clamped to ±limit_mm.
  double signed_distance(const Vec3& world, double limit_mm) const;
  double min_spacing_mm() const;
  double max_spacing_mm() const;

 private:
  const Volume<float>* field_;
  float level_;
};

// The segmentation's own boundary: the 0.5 level of its mask's trilinear interpolation (it
// crosses the voxel edges where marching cubes puts its vertices). The smoothed indicator's level set is the surface boundary
// vertices slide on (its normals are smooth); this one is what they are fitted to.
class MaskSurface {
 public:
  explicit MaskSurface(const Mask& mask) : mask_(&mask) {}
  // Signed distance (mm; outside positive) to first order, (0.5 − f) / |∇f|. The mask's field
  // is flat a voxel away from its level, so only the first voxel means anything: clamped to
  // ±limit_mm.
  double signed_distance(const Vec3& world, double limit_mm) const;
  double max_spacing_mm() const;
  const Mask& mask() const { return *mask_; }

 private:
  const Mask* mask_;
};

// Quality of tet t of the star of v, with v at x (see tet_quality for `floor`).
inline double quality_at(const WorkMesh& m, std::int32_t t, std::int32_t v, const Vec3& x,
                         double floor = -std::numeric_limits<double>::infinity()) {
  const Tet& tet = m.tets[t];
  const Vec3* p[4];
  for (int i = 0; i < 4; ++i) p[i] = tet[i] == v ? &x : &m.pos[tet[i]];
  return m.tet_quality(*p[0], *p[1], *p[2], *p[3], floor);
}

// A vertex move (the star's qualities at the new position are written apart).
struct Move {
  Vec3 position;
  bool moved = false;
};

// Greedy colouring in index order of the selected vertices: no two of one class share a tet.
// With two_rings, a selected boundary vertex also shares no tet with a neighbour of another
// selected vertex of its class: a boundary move changes the shape of the mesh around it, and is
// checked against the tets and vertices two rings out, which must stay put meanwhile.
std::vector<std::vector<std::int32_t>> colour_classes(const WorkMesh& mesh,
                                                      const std::vector<char>& selected,
                                                      bool two_rings);

// Runs move(v, star_quality_out) for every vertex of each colour class in parallel (their
// stars share no tet, so the moves are independent), then applies the moves in order; the
// mover writes the star's qualities (in vertex_tets order) where it is told. Returns the
// vertices moved; with mark_failures, those not moved are marked as failed.
std::vector<std::int32_t> move_in_classes(WorkMesh& mesh,
                                          const std::vector<std::vector<std::int32_t>>& classes,
                                          bool mark_failures,
                                          const std::function<Move(std::int32_t, double*)>& move);

// Boundary vertex v moved towards `target`: all, half or a quarter of the way, the first that
// keeps its star embedded and brings no tet below bad_below, nor below the star's worst when
// that is lower. Not moved when none does.
Move move_boundary_vertex(const WorkMesh& mesh, std::int32_t v, const Vec3& target,
                          double bad_below, double* star_quality);

// What one topological or smoothing pass did.
struct PassCounts {
  std::size_t edge_removals = 0;  // interior edge removed, its ring re-triangulated (3-2, 4-4, …)
  std::size_t face_flips = 0;     // 2-3 flips of an interior face
  std::size_t boundary_flips = 0;    // boundary edges removed (boundary diagonal swapped)
  std::size_t corner_removals = 0;   // corner tets removed with their corner vertex
  std::size_t moved_interior = 0;    // interior vertices moved
  std::size_t moved_surface = 0;     // boundary vertices moved along the surface
  std::size_t snapped_surface = 0;   // boundary vertices moved onto the surface (now sliding)
  std::size_t collapsed_edges = 0;   // short edges of needles collapsed (a vertex removed)
  std::size_t inserted = 0;          // interior vertices inserted
  std::size_t split_caps = 0;        // bad boundary caps split at their ridge
  double max_boundary_shift_mm = 0;  // largest boundary move of a boundary flip or corner (mm)
  double max_face_distance_mm = 0;   // … and largest distance of a new boundary face's centroid
                                     // to the surface (mm)
  double max_replaced_distance_mm = 0;  // … of the faces replaced, where the new ones are beyond
                                        // the tolerance (they are no farther; mm)
};

struct TopologyOptions {
  double bad_below = 1;        // tets of lower quality are worked on
  int max_rounds = 3;          // sweeps over the bad tets
  int max_ring = 9;            // edges with more tets around are not removed
  int edges_tried = 6;         // edges of a bad tet tried for removal, farthest dihedral
                               // angle from a regular tet's first
  bool interior_flips = true;  // edge removal and 2-3 flips inside
  bool boundary_flips = true;  // boundary edge flips where the boundary is convex, and corner
                               // removals …
  const LevelSetSurface* surface = nullptr;  // … and the new faces follow this surface: within
  double max_face_distance_mm = 0;           // this (mm), or no farther than the faces replaced
  double max_boundary_shift_mm = 0;  // without a surface: … moving it by at most this (mm)
};

// Flips (edge removal, 2-3 face flips, boundary edge flips, corner removals), each applied only
// when it raises the smallest quality of the tets it replaces; every tet below bad_below is tried,
// worst first. Planned in parallel, applied in order: deterministic whatever the thread count.
PassCounts improve_topology(WorkMesh& mesh, const TopologyOptions& options);

struct CollapseOptions {
  double bad_below = 1;           // tets of lower quality are worked on …
  double max_length_ratio = 0.4;  // … through each edge at most this × their longest one
  const LevelSetSurface* surface = nullptr;  // boundary edges collapse only with a surface, and
  double max_face_distance_mm = 0;           // the new boundary triangles within this of it
};

// Collapses the shortest edge of needles (see mesh_optimization_collapse.cpp): a vertex is
// removed (left without tets) when that keeps the topology and the boundary and raises the worst
// tet of its star. Sequential, worst tets first: deterministic.
PassCounts collapse_short_edges(WorkMesh& mesh, const CollapseOptions& options);

struct InsertionOptions {
  double bad_below = 1;      // tets of lower quality get a vertex inserted when that helps
  int max_cavity_tets = 48;  // larger cavities are not re-triangulated
  int max_rounds = 1;        // sweeps over the bad tets
};

// Inserts interior vertices into bad tets that flips and moves could not fix (see
// mesh_optimization_insertion.cpp). New vertices are appended. Planned in parallel, applied in
// order: deterministic whatever the thread count.
PassCounts insert_vertices(WorkMesh& mesh, const InsertionOptions& options);

struct SmoothingOptions {
  double bad_below = 1;            // vertices of tets of lower quality are moved
  int iterations = 4;              // ascent steps per vertex
  double max_step_fraction = 0.3;  // a step moves at most this fraction of the shortest edge
  bool move_interior = true;       // interior vertices move
  bool move_surface = true;        // boundary vertices in on_surface slide on the level set
};

// Moves vertices of bad tets to raise the smallest quality of their star (non-smooth ascent on
// the worst incident tets; a move is kept only when the star's minimum rises and no tet
// inverts). Boundary vertices move in the tangent plane and are projected back onto `surface`.
// Vertices are processed by colour classes (no two of one class share a tet) in parallel, so
// the result does not depend on the thread count.
PassCounts smooth_vertices(WorkMesh& mesh, const LevelSetSurface* surface,
                           const SmoothingOptions& options);

// Moves boundary vertices that are off `surface` (not in on_surface: interior sites the
// Delaunay exposed on the boundary) onto it, or part of the way when the whole way would fold
// their star or make a tet bad; a vertex brought within tolerance_mm joins on_surface, so it
// slides from then on. Colour classes in parallel: deterministic whatever the thread count.
PassCounts snap_to_surface(WorkMesh& mesh, const LevelSetSurface& surface, double tolerance_mm,
                           double bad_below);

struct BoundaryRefinementOptions {
  double tolerance_mm = 0;  // segmentation boundary farther than this from the mesh boundary
  double spacing_mm = 0;    // gets a vertex, one per this spacing
  double bad_below = 1;     // new tets are better than this or than the worst they replace
  std::size_t max_inserted = 0;  // vertices inserted at most
};
struct BoundaryRefinement {
  std::size_t far_points = 0;  // segmentation boundary points beyond the tolerance
  std::size_t inserted = 0;    // boundary vertices inserted
};

// Splits the boundary edges nearest the places where `object`'s boundary lies beyond the
// tolerance, each new vertex on `surface` (see mesh_optimization_boundary_refinement.cpp).
// Sequential, farthest first: deterministic. Both must outlive the refiner.
class BoundaryRefiner {
 public:
  BoundaryRefiner(const Mask& object, const LevelSetSurface& surface)
      : object_(&object), surface_(&surface) {}
  // The first run finds the object's boundary points beyond the tolerance; each run (a pass)
  // inserts where it can, and leaves the points not yet tried for the next.
  BoundaryRefinement run(WorkMesh& mesh, const BoundaryRefinementOptions& options);

  struct FarPoint {
    double distance;
    Vec3 at;
    std::int32_t face;  // nearest boundary face
  };

 private:
  const Mask* object_;
  const LevelSetSurface* surface_;
  std::vector<FarPoint> far_;
  bool scanned_ = false;
};

// A bad tet lying on the boundary with two boundary faces (a cap: flat across the ridge where
// they meet) that flips could not remove, because the new boundary would leave the surface, is
// split at its ridge's midpoint and the new vertex moved onto `surface`, as every boundary move
// (see move_boundary_vertex); kept only when that raises the worst tet around the ridge.
// Sequential, worst first: deterministic.
PassCounts split_bad_caps(WorkMesh& mesh, const LevelSetSurface& surface, double bad_below);

struct SurfaceFitOptions {
  int iterations = 2;      // Gauss–Newton steps
  double max_step_mm = 0;  // a vertex moves at most this far along the normal per step, and
  double min_step_mm = 0;  // not at all when less than this (its star is checked at a cost)
  double bad_below = 1;    // no tet is brought below this (nor below its star's worst)
};
struct SurfaceFit {
  std::size_t vertices = 0;               // boundary vertices that moved
  double mean_offset_mm = 0;              // their mean and largest distance from where they were
  double max_offset_mm = 0;
  double mean_error_before_mm = 0;        // area-weighted mean |signed distance| of the
  double mean_error_after_mm = 0;         // boundary triangles to the surface fitted to
};

// Fits the boundary triangles in the least-squares sense to `segmentation`'s boundary, or to
// the level set when it is null, by moving the on_surface vertices along the
// level set's normal (see mesh_optimization_fit.cpp). Colour classes in parallel: deterministic
// whatever the thread count.
SurfaceFit fit_to_surface(WorkMesh& mesh, const LevelSetSurface& surface,
                          const MaskSurface* segmentation, const SurfaceFitOptions& options);

// Lawson flips (2-3, 3-2) towards a Delaunay mesh, from the tets in `seeds`: a face whose
// opposite vertex lies inside the circumsphere is flipped when no new tet is bad, nor worse than
// the worst it replaces. Interior faces only. Sequential, deterministic.
PassCounts delaunay_flips(WorkMesh& mesh, const std::vector<std::int32_t>& seeds);

// Global ODT smoothing of the interior vertices (each moved towards the volume-weighted mean of
// its tets' circumcentres, kept only when no tet turns bad and no bad tet gets worse).
// Deterministic whatever the thread count (colour classes).
PassCounts odt_smooth(WorkMesh& mesh, int iterations, bool flips);

}  // namespace cvt::opt
