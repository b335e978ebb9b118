// Stage 6's options (see mesh_optimization.h for what each step does), and a table of them
// with key, label, tooltip and range that presets, the CLI and the viewer all share, so a new
// option is one struct member and one table row.
#pragma once

#include <string_view>
#include <type_traits>
#include <vector>

namespace cvt {

struct OptimizationOptions {
  // Tets with a dihedral angle below this or above 180° minus this are worked on (degrees).
  double target_dihedral_deg = 15;
  int max_passes = 10;  // a pass that changes nothing ends the optimisation early
  bool flips = true;    // edge removal and 2-3 flips
  // Boundary edge flips: where the boundary is convex, the diagonal of the quad of two boundary
  // triangles is swapped (the tets between re-triangulated, or a flat tet lying on the boundary
  // removed), and corner tets are removed, when the new triangles lie within
  // max_face_distance_voxels (smallest voxel spacings) of the segmentation surface (0.5 level;
  // centroids and new edge's midpoint) …
  bool boundary_flips = true;
  double max_face_distance_voxels = 0.5;
  double max_boundary_shift_mm = 0;  // … without the indicator: when the boundary moves by
                                     // at most this (mm; 0: no boundary flips)
  bool insert_vertices = true;       // insert interior vertices where flips cannot help
                                     // (appended after the input's vertices)
  bool smooth_interior = true;       // move interior vertices
  bool smooth_surface = true;        // slide boundary vertices on the level set (needs it)
  int smoothing_iterations = 4;      // ascent steps per vertex and pass
  // For the whole distribution, not only the bad tets (Table I's good bins): …
  int odt_passes = 2;              // … in the first passes, ODT sweeps over the interior
  int odt_iterations = 1;          //   vertices (this many per pass),
  int global_flip_passes = 1;      // … and in the first passes, flips also on tets whose
  double global_flip_below = 1.5;  //   quality (see min_quality) is below this, not only on
                                   //   bad ones (below 1). On the liver: +2.5 % good tets in
                                   //   each Table I measure for ~0.2 s.
  bool odt_flips = false;          // Delaunay flips after each ODT sweep (+1.5 % good
                                   // tets on the liver for +60 % time: off)
  // Boundary vertices farther than this from the level set (smallest voxel spacings) are not
  // surface samples (e.g. interior samples exposed by stage 5's peeling): they stay fixed.
  double surface_tolerance_voxels = 0.05;

  bool operator==(const OptimizationOptions&) const = default;
};

struct OptimizationField {
  std::string_view key;      // the member's name: preset key "optimization": {key: value},
                             // CLI option --opt-KEY (underscores as dashes)
  std::string_view label;    // short label in the viewer's panel
  std::string_view tooltip;  // meaning and unit
  // Exactly one of these points at the member.
  double OptimizationOptions::*real = nullptr;
  int OptimizationOptions::*integer = nullptr;
  bool OptimizationOptions::*flag = nullptr;
  double lo = 0, hi = 0;  // valid range of a number (inclusive)
};

// Every member of OptimizationOptions, in the viewer's panel order.
const std::vector<OptimizationField>& optimization_fields();

// Calls fn with the member of `o` that `f` names (a double, int or bool reference; const when
// `o` is), so readers and writers need not tell the three kinds apart.
template <class Options, class F>
void visit_field(const OptimizationField& f, Options& o, F&& fn) {
  if (f.real)
    fn(o.*f.real);
  else if (f.integer)
    fn(o.*f.integer);
  else
    fn(o.*f.flag);
}
// Copies the member `f` names from `from` to `to`.
inline void copy_field(const OptimizationField& f, const OptimizationOptions& from,
                       OptimizationOptions& to) {
  visit_field(f, to, [&](auto& member) {
    visit_field(f, from, [&](const auto& value) {
      if constexpr (std::is_same_v<std::decay_t<decltype(member)>, std::decay_t<decltype(value)>>)
        member = value;
    });
  });
}

// Throws InputError "optimization.KEY: must be in [lo, hi]" for a number out of its range.
void validate(const OptimizationOptions& options);
// Keeps every number in its range (the viewer's panel).
void clamp(OptimizationOptions& options);

}  // namespace cvt
