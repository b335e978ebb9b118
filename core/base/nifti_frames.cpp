#include "base/nifti_frames.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace cvt {
namespace {

// "code 2 aligned, RAS offset 90 -126 -72 mm".
std::string describe(const NiftiTransform& t) {
  static constexpr const char* kCodeNames[] = {"unknown",   "scanner", "aligned",
                                               "Talairach", "MNI",     "template"};
  const char* name = t.code >= 0 && t.code <= 5 ? kCodeNames[t.code] : "non-standard";
  char text[160];
  std::snprintf(text, sizeof text, "code %d %s, RAS offset %g %g %g mm", t.code, name,
                t.index_to_ras[3], t.index_to_ras[7], t.index_to_ras[11]);
  return text;
}

}  // namespace

Vec3 apply(const Affine& m, const Vec3& p) {
  return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
          m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
}

std::optional<NiftiFrame> frame_in_use(const NiftiTransforms& transforms, NiftiFrame asked) {
  const NiftiFrame other = asked == NiftiFrame::sform ? NiftiFrame::qform : NiftiFrame::sform;
  if (transforms[asked].set()) return asked;
  if (transforms[other].set()) return other;
  return std::nullopt;
}

std::string_view frame_name(std::optional<NiftiFrame> frame) {
  if (!frame) return "scaling";
  return *frame == NiftiFrame::qform ? "qform" : "sform";
}

Affine grid_index_to_ras(const Grid& g) {
  Affine m{};
  for (int r = 0; r < 3; ++r) {
    const double flip = r < 2 ? -1.0 : 1.0;  // LPS → RAS
    for (int c = 0; c < 3; ++c) m[4 * r + c] = flip * g.direction[3 * r + c] * g.spacing[c];
    m[4 * r + 3] = flip * g.origin[r];
  }
  m[15] = 1;
  return m;
}

double largest_corner_distance_mm(const Affine& a, const Affine& b,
                                  const std::array<int, 3>& dims) {
  double largest = 0;
  for (int corner = 0; corner < 8; ++corner) {
    Vec3 index;
    for (int axis = 0; axis < 3; ++axis)
      index[axis] = (corner >> axis & 1) ? dims[axis] - 0.5 : -0.5;
    largest = std::max(largest, distance(apply(a, index), apply(b, index)));
  }
  return largest;
}

double smallest_spacing_mm(const NiftiTransforms& transforms) {
  double smallest = std::numeric_limits<double>::infinity();
  for (const NiftiTransform* t : {&transforms.qform, &transforms.sform}) {
    if (!t->set()) continue;
    for (int c = 0; c < 3; ++c) {
      const Vec3 column{t->index_to_ras[c], t->index_to_ras[4 + c], t->index_to_ras[8 + c]};
      smallest = std::min(smallest, norm(column));
    }
  }
  return std::isfinite(smallest) ? smallest : 0.0;
}

std::string disagreement_warning(const std::string& path, const NiftiTransforms& t,
                                 const std::array<int, 3>& dims, std::optional<NiftiFrame> used) {
  if (!t.qform.set() || !t.sform.set()) return "";
  const double apart_mm =
      largest_corner_distance_mm(t.qform.index_to_ras, t.sform.index_to_ras, dims);
  if (!(apart_mm > kDisagreementVoxels * smallest_spacing_mm(t))) return "";
  const std::string_view other = used == NiftiFrame::qform ? "sform" : "qform";
  char apart[64];
  std::snprintf(apart, sizeof apart, "%.3g", apart_mm);
  return path + ": its qform (" + describe(t.qform) + ") and sform (" + describe(t.sform) +
         ") place the image up to " + apart + " mm apart; using the " +
         std::string(frame_name(used)) + " (--nifti-frame " + std::string(other) +
         " for the other)";
}

}  // namespace cvt
