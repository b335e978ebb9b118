// Optional clean-up of the binary object before meshing: drop small specks, fill cavities.
#pragma once

#include <cstddef>
#include <vector>

#include "base/volume.h"

namespace cvt {

struct CleanupOptions {
  bool remove_small_components = true;  // drop object components smaller than the fraction below
  double min_component_fraction = 0.01;  // of the largest component's voxel count
  bool fill_cavities = true;  // background components not reaching the crop border become object
};

struct CleanupReport {
  int components = 0;              // object components before clean-up (6-connected)
  int components_removed = 0;
  std::size_t voxels_removed = 0;
  int cavities_filled = 0;         // enclosed background components (6-connected) filled
  std::size_t voxels_filled = 0;
};

// Labels the 6-connected components of voxels equal to `value`: labels[v] = component id + 1,
// 0 elsewhere; returns the voxel count of each component.
std::vector<std::size_t> label_components(const Mask& mask, unsigned char value,
                                          std::vector<int>& labels);

CleanupReport clean_object(Mask& mask, const CleanupOptions& options);

}  // namespace cvt
