// Both transforms of a NIfTI header, read with niftilib (the copy ITK ships), and the grid of
// the one chosen. ITK 5.2 reads the qform unless the sform is a scanner frame or agrees with
// it; nibabel and FSL read the sform whenever its code is non-zero, so an atlas whose two
// transforms disagree lands where those tools show it only when we choose ourselves.
#include <nifti1_io.h>

#include <cmath>
#include <cstdio>
#include <memory>

#include "base/errors.h"
#include "io/image_io_internal.h"

namespace cvt::io_internal {
namespace {

// ITK's grid is kept when it places the image as the chosen transform does to within this
// many voxels (the header's float precision), so such files read exactly as before.
constexpr double kSameFrameVoxels = 1e-3;

Affine to_affine(const mat44& m) {
  Affine a{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) a[4 * r + c] = m.m[r][c];
  return a;
}

NiftiTransforms read_nifti_transforms(const std::string& path) {
  const std::unique_ptr<nifti_image, void (*)(nifti_image*)> header(
      nifti_image_read(path.c_str(), 0), nifti_image_free);  // 0: the header only
  if (!header) throw InputError(path + ": cannot read its NIfTI header");
  NiftiTransforms t;
  t.qform.code = header->qform_code;
  t.sform.code = header->sform_code;
  if (t.qform.set()) t.qform.index_to_ras = to_affine(header->qto_xyz);
  if (t.sform.set()) t.sform.index_to_ras = to_affine(header->sto_xyz);
  return t;
}

bool is_orthonormal(const std::array<double, 9>& d) {
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      const double product = d[a] * d[b] + d[3 + a] * d[3 + b] + d[6 + a] * d[6 + b];
      if (std::fabs(product - (a == b ? 1.0 : 0.0)) > 1e-6) return false;
    }
  return true;
}

// The rotation (or reflection) nearest to `d`, by niftilib's polar decomposition.
std::array<double, 9> nearest_orthonormal(const std::array<double, 9>& d) {
  mat33 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.m[r][c] = float(d[3 * r + c]);
  const mat33 q = nifti_mat33_polar(m);
  std::array<double, 9> out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[3 * r + c] = q.m[r][c];
  return out;
}

// The LPS grid that places voxels as `index_to_ras` does: spacing from the lengths of its
// columns, directions from their directions. A sheared affine has no such grid; its nearest
// rotation stands in for it (the caller measures how far that is).
Grid grid_of(const Affine& index_to_ras, const std::array<int, 3>& dims) {
  Grid g;
  g.dims = dims;
  for (int c = 0; c < 3; ++c)
    g.spacing[c] = norm(Vec3{index_to_ras[c], index_to_ras[4 + c], index_to_ras[8 + c]});
  for (int r = 0; r < 3; ++r) {
    const double flip = r < 2 ? -1.0 : 1.0;  // RAS → LPS
    // (+ 0.0: no negative zeros from the flip in what info prints)
    for (int c = 0; c < 3; ++c)
      g.direction[3 * r + c] = flip * index_to_ras[4 * r + c] / g.spacing[c] + 0.0;
    g.origin[r] = flip * index_to_ras[4 * r + 3] + 0.0;
  }
  if (!is_orthonormal(g.direction)) g.direction = nearest_orthonormal(g.direction);
  return g;
}

std::string mm_text(double mm) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", mm);
  return text;
}

}  // namespace

void place_in_nifti_frame(Image& image, const std::string& path, NiftiFrame asked) {
  const NiftiTransforms transforms = read_nifti_transforms(path);
  const std::optional<NiftiFrame> used = frame_in_use(transforms, asked);
  const std::array<int, 3> dims = image.grid().dims;
  image.nifti = transforms;
  image.frame = frame_name(used);
  if (std::string w = disagreement_warning(path, transforms, dims, used); !w.empty())
    image.warnings.push_back(std::move(w));
  if (!used) return;  // the voxel spacing alone, as ITK reads it (origin 0)
  const Affine& chosen = transforms[*used].index_to_ras;
  const double voxel_mm = smallest_spacing_mm(transforms);
  if (largest_corner_distance_mm(grid_index_to_ras(image.grid()), chosen, dims) <=
      kSameFrameVoxels * voxel_mm)
    return;
  const Grid grid = grid_of(chosen, dims);
  const double off_mm = largest_corner_distance_mm(grid_index_to_ras(grid), chosen, dims);
  if (off_mm > kDisagreementVoxels * voxel_mm) {
    const std::string name(frame_name(used));
    image.warnings.push_back(path + ": its " + name + " is sheared, which cvtmesh's grids " +
                             "cannot follow; using its nearest rotation, up to " + mm_text(off_mm) +
                             " mm away from it");
  }
  image.voxels.grid = grid;
}

}  // namespace cvt::io_internal
