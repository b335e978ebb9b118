// Helpers the per-library readers and writers share (defined in image_io.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include "base/image.h"

namespace cvt::io_internal {

// `text` on one line: newlines and repeated spaces folded (library messages are multi-line).
std::string one_line(const std::string& text);
bool is_integer_pixel_type(const std::string& type);
// dims[0]·dims[1]·dims[2], refusing zero, overflow and sizes beyond memory (InputError naming path).
std::size_t checked_voxel_count(const std::array<unsigned long long, 3>& dims,
                                const std::string& path);
// Converts `count` values of `src_type` to float; labels beyond 2^24 are refused.
void convert_to_float(const void* src, const std::string& src_type, std::size_t count, float* dst,
                      bool labels, const std::string& path);
// The pixel type to write, checked against the image's values.
std::string checked_write_pixel_type(const Image& image, const std::string& path);
// Throws InputError when the file at `path` holds fewer than `expected` bytes.
void require_complete_file(const std::string& path, std::size_t expected);
// For a NIfTI `image` as ITK read it from `path`: records both header transforms, places the
// image in the frame `asked` chooses (nifti_frame_io.cpp) and warns when the two disagree.
void place_in_nifti_frame(Image& image, const std::string& path, NiftiFrame asked);

}  // namespace cvt::io_internal
