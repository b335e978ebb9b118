// An image as read from disk: geometry plus one value per voxel.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "base/nifti_frames.h"
#include "base/volume.h"

namespace cvt {

struct Image {
  Volume<float> voxels;        // values; integer labels are stored exactly (|label| < 2^24)
  bool integer_valued = true;  // true for label images (any integer pixel type)
  std::string pixel_type;      // e.g. "uint8", "int16", "float32" (as stored on disk)
  std::string source;          // the path it was read from
  // NIfTI only: both of the header's transforms, and the one that placed the image ("sform",
  // "qform" or "scaling"; empty for other formats).
  std::optional<NiftiTransforms> nifti;
  std::string frame;
  std::vector<std::string> warnings;  // one line each, for the user (how it was read)

  const Grid& grid() const { return voxels.grid; }
};

struct ValueRange {
  double min = 0, max = 0;
};
// Of the finite voxels ({0, 0} when there are none).
ValueRange value_range(const Image& image);

// Voxel count per integer label (only for integer-valued images).
std::map<std::int64_t, std::size_t> label_histogram(const Image& image);

}  // namespace cvt
