// Reading and writing images in physical space. The format is chosen by the path:
//   .nii .nii.gz .nrrd .nhdr .mha .mhd       → ITK
//   a folder holding DICOM files              → ITK (GDCM), the first series found
//   .inr .inr.gz                              → CGAL ImageIO (origin 0, identity direction)
//   a folder of .tif/.tiff/.png slices        → libtiff/libpng, slices sorted by name
// Every failure throws InputError with one line naming the path and the problem.
#pragma once

#include <string>

#include "base/image.h"
#include "base/nifti_frames.h"

namespace cvt {

struct ReadOptions {
  Vec3 slice_spacing_mm{1, 1, 1};  // spacing for a folder of 2D slices (no geometry on disk)
  std::size_t max_bytes = 0;       // refuse images needing more memory than this; 0 = available RAM
  // NIfTI: the header transform that places the image when its code is non-zero (else the
  // other one, else the voxel spacing alone). The sform by default, as nibabel and FSL read it.
  NiftiFrame nifti_frame = NiftiFrame::sform;
};

Image read_image(const std::string& path, const ReadOptions& options = {});

// Writes `image` (its values cast to the pixel type named by image.pixel_type) to `path`,
// format by extension (.nii .nii.gz .nrrd .mha .mhd via ITK, .inr/.inr.gz via CGAL).
// Writes to a temporary file beside `path` and renames it, so no partial file is left.
void write_image(const Image& image, const std::string& path);

// Lower-case extension including compound ones: "nii.gz", "inr.gz", "nrrd", ... ("" if none).
std::string image_extension(const std::string& path);

// Implementations per library (image_io.cpp dispatches to these).
Image read_image_itk(const std::string& path, const ReadOptions& options);
Image read_dicom_series_itk(const std::string& folder, const ReadOptions& options);
Image read_image_inr(const std::string& path, const ReadOptions& options);
Image read_slice_folder(const std::string& folder, const ReadOptions& options);
void write_image_itk(const Image& image, const std::string& path);
void write_image_inr(const Image& image, const std::string& path);

}  // namespace cvt
