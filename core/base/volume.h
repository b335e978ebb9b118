// A scalar field on a Grid: one value per voxel, i fastest.
#pragma once

#include <vector>

#include "base/grid.h"
#include "base/memory.h"

namespace cvt {

template <class T>
struct Volume {
  Grid grid;
  std::vector<T> data;

  Volume() = default;
  // The pages of a large volume are faulted in by all threads first (fault_in_pages).
  explicit Volume(const Grid& g, T fill = T()) : grid(g) {
    data.reserve(g.voxel_count());
    fault_in_pages(data.data(), data.capacity() * sizeof(T));
    data.assign(g.voxel_count(), fill);
  }

  T& at(int i, int j, int k) { return data[grid.linear(i, j, k)]; }
  const T& at(int i, int j, int k) const { return data[grid.linear(i, j, k)]; }
  std::size_t size() const { return data.size(); }
};

// Binary object: 1 inside, 0 outside.
using Mask = Volume<unsigned char>;

}  // namespace cvt
