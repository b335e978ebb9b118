// Optional clean-up of the binary object before meshing: drop small specks, fill cavities.
#pragma once

#include <cstddef>
#include <vector>

#include "base/volume.h"

namespace cvt {

struct CleanupOptions {
  bool remove_small_components = true;  // drop object components smaller than the fraction below
  double min_component_fraction = 0.01;  // of the largest component's voxel count
  // Background components not reaching the crop border (cavities) become object when they are
  // small next to it: at most max_cavity_fraction of the object's voxels. A large cavity is
  // anatomy (a skull's cranial cavity, a heart's blood pool) and stays a hole.
  bool fill_cavities = true;
  double max_cavity_fraction = 0.01;
};

struct CleanupReport {
  int components = 0;              // object components before clean-up (6-connected)
  int components_removed = 0;
  std::size_t voxels_removed = 0;
  int cavities_filled = 0;         // enclosed background components (6-connected) filled
  std::size_t voxels_filled = 0;
  int cavities_kept = 0;  // enclosed background components left as holes (too large to fill)
  std::size_t voxels_kept = 0;
};

// Labels the 6-connected components of voxels equal to `value`: labels[v] = component id + 1,
// 0 elsewhere; returns the voxel count of each component.
std::vector<std::size_t> label_components(const Mask& mask, unsigned char value,
                                          std::vector<int>& labels);

CleanupReport clean_object(Mask& mask, const CleanupOptions& options);

}  // namespace cvt
