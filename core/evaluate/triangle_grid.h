// Exact distances from points to a triangle surface, for many queries against a surface of many
// small triangles (a marching-cubes surface has about a million, each half a voxel): triangles
// bucketed into a uniform grid of cubic cells, searched ring by ring around the query.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "fields/marching_cubes.h"

namespace cvt {

// Squared distance from p to the closest point of the triangle (a, b, c); a degenerate triangle
// (a segment, a point, a needle) counts as its edges.
double point_triangle_squared_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

class TriangleGrid {
 public:
  // Cells of cell_mm (≤ 0: twice the mean longest triangle edge) over the bounding box of the
  // triangles, at most about four cells per triangle. Each triangle is listed in every cell its
  // bounding box meets. Keeps a reference to `surface`, which must outlive the grid.
  explicit TriangleGrid(const TriangleSurface& surface, double cell_mm = 0);

  bool empty() const { return entries_.empty(); }
  double cell_mm() const { return cell_; }

  // Squared distance from p to the nearest triangle (+inf when there is none). Exact: the rings
  // of cells around p are searched until no unsearched cell can hold a nearer point, and the
  // minimum of exact distances does not depend on the order they are found in. `nearest`, if
  // given, is a triangle to try first (a neighbour's answer makes the search quick; −1: none) and
  // receives the nearest one.
  double squared_distance(const Vec3& p, std::int32_t* nearest = nullptr) const;

 private:
  int cell_of(double v, int a) const;
  // Gap along axis a between coordinate v and the slab of cells with index c.
  double gap(int c, int a, double v) const;

  // A triangle listed in a cell, with a sphere around it to skip it cheaply.
  struct Entry {
    float x, y, z, radius;  // centroid, and the farthest vertex (rounded up)
    std::int32_t triangle;
  };

  const TriangleSurface* surface_;
  Vec3 lo_;
  double cell_ = 1;
  std::array<int, 3> n_{1, 1, 1};
  std::vector<std::uint32_t> start_;  // per cell (x fastest): first entry; one past the end
  std::vector<Entry> entries_;        // cell by cell, triangles ascending in a cell
};

}  // namespace cvt
