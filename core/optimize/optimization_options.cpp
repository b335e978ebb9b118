#include "optimize/optimization_options.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "base/errors.h"

namespace cvt {

const std::vector<OptimizationField>& optimization_fields() {
  using O = OptimizationOptions;
  auto real = [](std::string_view key, std::string_view label, std::string_view tip,
                 double O::*m, double lo, double hi) {
    OptimizationField f{key, label, tip};
    f.real = m, f.lo = lo, f.hi = hi;
    return f;
  };
  auto integer = [](std::string_view key, std::string_view label, std::string_view tip,
                    int O::*m, double lo, double hi) {
    OptimizationField f{key, label, tip};
    f.integer = m, f.lo = lo, f.hi = hi;
    return f;
  };
  auto flag = [](std::string_view key, std::string_view label, std::string_view tip, bool O::*m) {
    OptimizationField f{key, label, tip};
    f.flag = m;
    return f;
  };
  static const std::vector<OptimizationField> fields{
      real("target_dihedral_deg", "target dihedral (°)",
           "Tets with a dihedral angle below this, or above 180° minus this, are bad and worked "
           "on (degrees).",
           &O::target_dihedral_deg, 1, 35),
      integer("max_passes", "max passes",
              "Most passes of stage 6; a pass that changes nothing ends it early (count).",
              &O::max_passes, 0, 100),
      flag("flips", "flips", "Edge removal (3-2, 4-4, ...) and 2-3 face flips on bad tets.",
           &O::flips),
      flag("boundary_flips", "boundary flips",
           "Swap the diagonal of two boundary triangles where the boundary is convex, and remove "
           "corner tets, when the new triangles follow the segmentation surface.",
           &O::boundary_flips),
      real("max_face_distance_voxels", "max face distance (voxels)",
           "Boundary flips: largest distance of a new boundary triangle from the surface (0.5 "
           "level), in smallest voxel spacings.",
           &O::max_face_distance_voxels, 0, 5),
      real("max_boundary_shift_mm", "max boundary shift (mm)",
           "Boundary flips without the smoothed indicator: largest boundary move allowed (mm; "
           "0 = none).",
           &O::max_boundary_shift_mm, 0, 10),
      flag("insert_vertices", "insert vertices",
           "Insert interior vertices where flips and moves cannot help (appended after the "
           "mesh's vertices).",
           &O::insert_vertices),
      flag("smooth_interior", "move interior vertices",
           "Move interior vertices to raise the worst tet of their star.", &O::smooth_interior),
      flag("smooth_surface", "slide surface vertices",
           "Slide boundary vertices along the sub-voxel surface (0.5 level of the smoothed "
           "indicator).",
           &O::smooth_surface),
      integer("smoothing_iterations", "smoothing iterations",
              "Ascent steps per vertex and pass (count).", &O::smoothing_iterations, 0, 50),
      integer("odt_passes", "ODT passes",
              "In this many first passes, a global ODT sweep moves the interior vertices "
              "towards the volume-weighted mean of their tets' circumcentres (count).",
              &O::odt_passes, 0, 100),
      integer("odt_iterations", "ODT iterations", "ODT sweeps per such pass (count).",
              &O::odt_iterations, 0, 20),
      flag("odt_flips", "flips after ODT",
           "Delaunay flips after each ODT sweep (a little better, much slower).", &O::odt_flips),
      integer("global_flip_passes", "global flip passes",
              "In this many first passes, flips also work on mediocre tets (quality below the "
              "next value), not only bad ones (count).",
              &O::global_flip_passes, 0, 100),
      real("global_flip_below", "global flip below",
           "Quality below which those passes flip a tet (1 = bad; the quality is the smallest "
           "of each measure over its bad-bin edge, unitless).",
           &O::global_flip_below, 1, 10),
      real("surface_tolerance_voxels", "surface tolerance (voxels)",
           "Boundary vertices farther than this from the surface are not surface samples and "
           "stay fixed (smallest voxel spacings).",
           &O::surface_tolerance_voxels, 0, 2),
  };
  return fields;
}

void validate(const OptimizationOptions& o) {
  for (const OptimizationField& f : optimization_fields()) {
    const double v = f.real ? o.*f.real : f.integer ? double(o.*f.integer) : 0.0;
    if (f.flag || (std::isfinite(v) && v >= f.lo && v <= f.hi)) continue;
    std::ostringstream s;
    s << "optimization." << f.key << ": must be in [" << f.lo << ", " << f.hi << "]";
    throw InputError(s.str());
  }
}

void clamp(OptimizationOptions& o) {
  for (const OptimizationField& f : optimization_fields()) {
    if (f.real) o.*f.real = std::clamp(std::isfinite(o.*f.real) ? o.*f.real : f.lo, f.lo, f.hi);
    if (f.integer) o.*f.integer = std::clamp(o.*f.integer, int(f.lo), int(f.hi));
  }
}

}  // namespace cvt
