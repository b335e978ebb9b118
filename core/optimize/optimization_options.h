// Stage 6's options (see mesh_optimization.h for what each step does). Their keys, ranges,
// labels and meanings are rows of the parameter registry (pipeline/parameter_registry.cpp),
// like every other parameter.
#pragma once

namespace cvt {

struct OptimizationOptions {
  double target_dihedral_deg = 15;  // tets with a dihedral below this (or above 180° − it) are bad
  int max_passes = 10;              // a pass that changes nothing ends the optimisation early
  bool flips = true;                // edge removal and 2-3 flips
  bool boundary_flips = true;       // swap boundary diagonals where the boundary is convex
  double max_face_distance_voxels = 0.5;  // … when new triangles stay this close to the surface
  double max_boundary_shift_mm = 0;       // … without the indicator: when the boundary moves
                                          //     by at most this (0: no boundary flips)
  bool insert_vertices = true;            // interior vertices where flips cannot help
  bool smooth_interior = true;            // move interior vertices
  bool smooth_surface = true;             // slide boundary vertices on the level set
  int smoothing_iterations = 4;           // ascent steps per vertex and pass
  int odt_passes = 2;                     // first passes with a global ODT sweep …
  int odt_iterations = 1;                 // … of this many iterations
  int global_flip_passes = 3;             // first passes that flip mediocre tets too …
  double global_flip_below = 1.5;         // … those of quality below this
  bool odt_flips = false;                 // Delaunay flips after each ODT sweep
  double surface_tolerance_voxels = 0.05;  // boundary vertices farther off stay fixed
  // In the second and third passes: where the segmentation's boundary lies farther than the
  // tolerance from the mesh boundary, a boundary vertex is inserted …
  bool refine_boundary = true;
  double boundary_tolerance_mm = 0;  // … (mm; 0: auto_boundary_tolerance_mm)
  bool fit_surface = true;  // last: boundary fitted to the surface (least squares, not chords)

  bool operator==(const OptimizationOptions&) const = default;
};

// The boundary tolerance's default from the object's sizing unit (object_scale.h): in mm, so a
// finer scan of the same anatomy gets the same tolerance.
inline double auto_boundary_tolerance_mm(double sizing_unit_mm) { return 0.5 * sizing_unit_mm; }

// Throws InputError "optimization.KEY: ..." for a value out of its range. Defined by the
// parameter registry, which holds the ranges.
void validate(const OptimizationOptions& options);

}  // namespace cvt
