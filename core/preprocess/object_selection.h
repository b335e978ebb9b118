// Turning an image into the binary object to mesh: which voxels are "inside", cropped to their
// bounding box plus a margin and padded, so objects touching the image border are closed.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/image.h"

namespace cvt {

struct ObjectSelection {
  std::vector<std::int64_t> labels;  // labels that make the object; empty = all non-zero
  std::optional<double> iso;         // grey images: threshold value (replaces labels)
  bool inside_above = true;          // with iso: inside is value ≥ iso (else value ≤ iso)
  int margin_voxels = 4;             // background voxels kept around the object's bounding box
};

// "all", "255", "1,2,5" → labels (throws InputError naming --labels on bad text).
std::vector<std::int64_t> parse_label_list(const std::string& text);
std::string describe(const ObjectSelection& selection);

// The object as a mask on a sub-grid of the image (same spacing/direction, shifted origin).
// Throws InputError naming the image when the selection is empty, when a grey image has no iso
// value, or when the image holds NaN/Inf.
Mask select_object(const Image& image, const ObjectSelection& selection);

}  // namespace cvt
