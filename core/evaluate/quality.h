// Stage 7: element quality (the paper's Table I measures after Shewchuk 2002, dihedral angles,
// radius–edge ratio) and mesh validity (orientation, references, closed 2-manifold boundary).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string_view>
#include <vector>

#include "base/tet_mesh.h"

namespace cvt {

// Per-tet figures. The first three are Shewchuk's raw (unnormalised) measures; larger is better,
// an inverted tet scores negative (signed volume), a flat one 0.
enum class Measure {
  VOverRmc3,        // V / r_mc³, r_mc = radius of the smallest sphere containing the tet
  GradientError,    // V · (Σ_m A_m / Σ_{i<j} A_i A_j ℓ_ij²)^{3/4}
  ConditionNumber,  // V / ((1/4) Σ_i A_i²)^{3/4}
  MinDihedralDeg,   // smallest of the six dihedral angles (degrees)
  MaxDihedralDeg,   // largest of the six dihedral angles (degrees)
  RadiusEdge,       // circumradius / shortest edge (≥ √6/4; +inf for a flat tet)
};
inline constexpr std::array<Measure, 3> kShewchukMeasures{
    Measure::VOverRmc3, Measure::GradientError, Measure::ConditionNumber};

// JSON key / display name: "v_over_rmc3", "gradient_error", "condition_number", ...
std::string_view measure_key(Measure m);
// Value of a regular tet (the best possible for the Shewchuk measures and the radius–edge ratio):
// 0.5132, 0.1629, 0.4136, 70.53°, 70.53°, 0.6124. Multiply a raw measure by 1/this to normalise.
double regular_tet_value(Measure m);
// Table I bin edges (lo, hi): bins are Q < lo, lo ≤ Q ≤ hi, Q > hi.
std::array<double, 2> table1_bin_edges(Measure m);

// Single-tet geometry (any vertex order; volume sign follows (b−a)·((c−a)×(d−a))).
double min_containing_ball_radius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
double circumradius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);  // inf if flat
// The six dihedral angles (degrees) at edges 01, 02, 03, 12, 13, 23.
std::array<double, 6> dihedral_angles_deg(const Vec3& a, const Vec3& b, const Vec3& c,
                                          const Vec3& d);
double tet_measure(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, Measure m);

// Every per-tet figure at once (what tet_measure and dihedral_angles_deg each compute in full).
struct TetFigures {
  double shewchuk[3];  // V/r_mc³, gradient error, condition number (not normalised)
  std::array<double, 6> dihedral{};
  double min_dihedral, max_dihedral, radius_edge;
};
// Without all_dihedrals, `dihedral` is left zero (unless a face has no area) and only the
// extremes are computed, at the edges found by a pseudo-angle: two angles instead of six.
TetFigures tet_figures(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                       bool all_dihedrals = true);
double measure_of(const TetFigures& f, Measure m);

// Every measure, one value per tet of `mesh`, indexed by Measure (parallel, each tet's figures
// computed once); for a GUI colour map.
inline constexpr int kMeasureCount = 6;
std::array<std::vector<double>, kMeasureCount> tet_measures(const TetMesh& mesh);

struct QualityOptions {
  int histogram_bins = 20;        // bins of the per-measure histograms
  double dihedral_bin_deg = 5.0;  // width of the dihedral histogram bins (divides 180)
  double radius_edge_max = 3.0;  // radius–edge histogram covers [√6/4, this]; larger → last bin
};

// Distribution of one per-tet value.
struct MeasureStats {
  double min = 0, mean = 0, max = 0;        // over all tets (finite values only)
  std::array<double, 3> bins_percent{};     // Table I bins (Shewchuk measures only), sum 100
  std::array<double, 2> histogram_range{};  // histogram covers [lo, hi]; outside → end bins
  std::vector<std::size_t> histogram;       // tet counts per bin
  std::size_t non_finite = 0;               // tets with a non-finite value (flat: radius–edge)
};

struct DihedralStats {
  double min_deg = 0, max_deg = 0;                      // over all tets and all six angles
  std::size_t below_5 = 0, below_10 = 0, below_20 = 0;  // tets whose min dihedral is below
  std::size_t above_160 = 0, above_170 = 0;             // tets whose max dihedral is above
  double bin_deg = 5;                                   // histogram bin width
  std::vector<std::size_t> histogram;  // all 6·#tets angles, bins of bin_deg over [0,180]
};

// Topology of a triangle surface (for a tet mesh: its boundary).
struct SurfaceTopology {
  std::size_t vertices = 0, edges = 0, triangles = 0;  // the ones triangles use
  std::size_t non_manifold_edges = 0;                  // edges not in exactly two triangles
  std::size_t misoriented_edges = 0;                   // edges used twice in the same direction
  std::size_t non_manifold_vertices = 0;  // triangles around the vertex: not one cycle (fan)
  bool closed_manifold = false;           // none of the three above, and not empty
  long long euler_characteristic = 0;     // V − E + F (sphere 2, torus 0)
  std::size_t components = 0;             // connected components
};
SurfaceTopology surface_topology(const std::vector<Triangle>& triangles, std::size_t vertex_count);

struct Validity {
  std::size_t inverted = 0;     // tets with signed volume < 0 (and not zero volume)
  std::size_t zero_volume = 0;  // |V| ≤ 1e-12 ℓ_max³ or a repeated vertex
  std::size_t unreferenced_vertices = 0;
  std::size_t faces_shared_by_more_than_two = 0;  // non-manifold faces (count of such faces)
  std::size_t overlapping_faces = 0;  // interior faces whose two tets lie on the same side
  SurfaceTopology boundary;           // of the faces used by exactly one tet
  bool valid = false;                 // all of the above fine, closed manifold, ≥ 1 tet
};

struct QualityReport {
  std::size_t tets = 0, vertices = 0;
  double volume_mm3 = 0;                 // Σ signed volumes
  std::array<MeasureStats, 3> shewchuk;  // in kShewchukMeasures order
  DihedralStats dihedral;
  MeasureStats radius_edge;
  Validity validity;
};

// Every figure (parallel: ~0.4 s of CPU per million tets). Throws InputError when a tet
// references a vertex that does not exist.
QualityReport compute_quality(const TetMesh& mesh, const QualityOptions& options = {});
// Validity alone (the topology part of compute_quality).
Validity check_validity(const TetMesh& mesh);

// Faces of a mesh by how many tets use them (sorted face matching, parallel).
struct FaceUse {
  std::vector<Triangle> boundary;           // used once, oriented outward, in (tet, face) order
  std::size_t shared_by_more_than_two = 0;  // faces used by three or more tets
  std::size_t overlapping = 0;              // faces used twice by tets on the same side
};
FaceUse classify_faces(const TetMesh& mesh);

// Layout printed by `cvtmesh quality --json`: {"tets","vertices","volume_mm3","measures":{key:
// {"bins_percent","bin_edges","min","mean","max","normalizer","histogram","histogram_range"}},
// "dihedral_deg":{...},"radius_edge":{...},"validity":{...}}.
nlohmann::json to_json(const QualityReport& report);

}  // namespace cvt
