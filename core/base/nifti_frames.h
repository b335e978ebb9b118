// The two transforms of a NIfTI header, the qform and the sform, and the choice between them.
// Both map a voxel index (i, j, k) to RAS millimetres, as the header stores them; cvtmesh's
// physical space is ITK's LPS (x and y negated), in which meshes are written.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "base/grid.h"

namespace cvt {

// Two placements of the image that differ by more than this many voxels anywhere disagree.
constexpr double kDisagreementVoxels = 0.1;

// Which of the header's transforms places the image.
enum class NiftiFrame { qform, sform };

// Voxel index → position (mm), a row-major 4×4 matrix whose last row is 0 0 0 1.
using Affine = std::array<double, 16>;
Vec3 apply(const Affine& affine, const Vec3& index);

struct NiftiTransform {
  // qform_code or sform_code: 0 not set, 1 scanner, 2 aligned, 3 Talairach, 4 MNI, 5 template.
  int code = 0;
  Affine index_to_ras{};  // meaningful when code > 0
  bool set() const { return code > 0; }
};

struct NiftiTransforms {
  NiftiTransform qform, sform;
  const NiftiTransform& operator[](NiftiFrame frame) const {
    return frame == NiftiFrame::qform ? qform : sform;
  }
};

// The transform that places the image: `asked` when its code is non-zero, else the other one
// when its code is; none (the voxel spacing alone) when neither is set.
std::optional<NiftiFrame> frame_in_use(const NiftiTransforms& transforms, NiftiFrame asked);
// "qform", "sform", or "scaling" for none.
std::string_view frame_name(std::optional<NiftiFrame> frame);

// The index → RAS map of a grid in cvtmesh's (LPS) physical space.
Affine grid_index_to_ras(const Grid& grid);
// The largest distance (mm) between where `a` and `b` put a point of the image box (the
// voxels of `dims`, to their outer faces). Both maps are affine, so it is the largest at the
// box's 8 corners.
double largest_corner_distance_mm(const Affine& a, const Affine& b, const std::array<int, 3>& dims);
// The smallest voxel spacing (mm) of the set transforms (0 if none is set).
double smallest_spacing_mm(const NiftiTransforms& transforms);

// One line naming both transforms (codes and offsets) when both are set and they place the
// image more than a tenth of a voxel apart anywhere; "" otherwise. `path` starts the line.
std::string disagreement_warning(const std::string& path, const NiftiTransforms& transforms,
                                 const std::array<int, 3>& dims, std::optional<NiftiFrame> used);

}  // namespace cvt
