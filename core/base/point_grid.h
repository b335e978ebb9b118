// Points bucketed into a uniform grid of cubic cells, for the range queries of the samplers and
// the mesher: every point within a radius, whether there is one, and the points of the cells
// near a box (the nearest-site candidates, sampling/nearest_site.h).
//
// Built once, in CSR form: cells in (k, j, i) order, the points of a cell contiguous and in
// input order, their coordinates copied in that order (structure of arrays, for vector code).
// The cells cover a box given at construction; points outside it fall into the border cells.
// Every query stays exact because clamping to the grid is monotone, and the queries visit
// points in storage order, so their results do not depend on anything but the input.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "base/vec3.h"

namespace cvt {

class PointGrid {
 public:
  // Cells of cell_mm (≤ 0: about one point per cell) over the box [lo, hi] (mm), never much more
  // than 64 cells per point.
  PointGrid(const std::vector<Vec3>& points, const Vec3& lo, const Vec3& hi, double cell_mm);
  // Over the bounding box of the points.
  PointGrid(const std::vector<Vec3>& points, double cell_mm);

  std::size_t size() const { return id_.size(); }
  double cell_mm() const { return cell_; }
  const std::array<int, 3>& cells() const { return n_; }  // along x, y, z

  // Calls f(index, squared distance) for every point strictly within `radius` of c.
  template <class F>
  void for_each_within(const Vec3& c, double radius, F&& f) const;
  // Whether some point lies strictly within `radius` of c; with `keep`, one whose index i has
  // keep(i).
  bool any_within(const Vec3& c, double radius) const;
  template <class Keep>
  bool any_within(const Vec3& c, double radius, Keep&& keep) const;

  // For queries with their own filter. Points are addressed by their position `at` in storage
  // order: index(at) is the point's index in the input, x(at), y(at), z(at) its coordinates.
  // Cell of coordinate v along axis a (0 = x), clamped to the grid.
  int cell_of(double v, int a) const {
    // Truncation is the floor once clamped at 0; NaN goes to 0.
    return int(std::max(0.0, std::min((v - lo_[a]) / cell_, double(n_[a] - 1))));
  }
  // Calls f(at) for the points of the cells c0..c1 (inclusive, per axis).
  template <class F>
  void for_each_in_cells(const std::array<int, 3>& c0, const std::array<int, 3>& c1, F&& f) const;
  // Calls f(begin, end) for runs [begin, end) of positions that together hold the points of
  // every cell within √r2 of the box [lo, hi], one run per row of cells along x: the rows the
  // distance leaves after their y and z gaps to the box (a rounded box, about half the cells of
  // the dilated box). Border cells reach to infinity.
  template <class F>
  void for_each_run_near(const Vec3& lo, const Vec3& hi, double r2, F&& f) const;
  const std::int32_t* index() const { return id_.data(); }
  const double* x() const { return x_.data(); }
  const double* y() const { return y_.data(); }
  const double* z() const { return z_.data(); }

 private:
  // Gap along axis a between [lo, hi] and cell c; border cells reach to infinity.
  double cell_gap(int c, int a, double lo, double hi) const {
    constexpr double inf = std::numeric_limits<double>::infinity();
    const double c_lo = c == 0 ? -inf : lo_[a] + c * cell_;
    const double c_hi = c == n_[a] - 1 ? inf : lo_[a] + (c + 1) * cell_;
    return std::max(0.0, std::max(c_lo - hi, lo - c_hi));
  }
  std::size_t row_of(int j, int k) const { return (std::size_t(k) * n_[1] + j) * n_[0]; }
  // Calls f(at) for the points of cells c0..c1 until f returns true; returns whether it did.
  template <class F>
  bool find_in_cells(const std::array<int, 3>& c0, const std::array<int, 3>& c1, F&& f) const;
  // The cells c0..c1 that can hold points within `radius` of c.
  void cells_around(const Vec3& c, double radius, std::array<int, 3>& c0,
                    std::array<int, 3>& c1) const {
    for (int a = 0; a < 3; ++a)
      c0[a] = cell_of(c[a] - radius, a), c1[a] = cell_of(c[a] + radius, a);
  }

  Vec3 lo_;
  double cell_ = 1;
  std::array<int, 3> n_{1, 1, 1};
  std::vector<std::int32_t> start_;  // per cell: position of its first point; one past the end
  std::vector<std::int32_t> id_;     // per position: index in the input
  std::vector<double> x_, y_, z_;    // per position: coordinates (mm)
};

template <class F>
bool PointGrid::find_in_cells(const std::array<int, 3>& c0, const std::array<int, 3>& c1,
                              F&& f) const {
  for (int k = c0[2]; k <= c1[2]; ++k)
    for (int j = c0[1]; j <= c1[1]; ++j) {
      const std::size_t row = row_of(j, k);
      for (std::int32_t at = start_[row + c0[0]]; at < start_[row + c1[0] + 1]; ++at)
        if (f(at)) return true;
    }
  return false;
}

template <class F>
void PointGrid::for_each_in_cells(const std::array<int, 3>& c0, const std::array<int, 3>& c1,
                                  F&& f) const {
  find_in_cells(c0, c1, [&](std::int32_t at) {
    f(at);
    return false;
  });
}

template <class F>
void PointGrid::for_each_within(const Vec3& c, double radius, F&& f) const {
  std::array<int, 3> c0, c1;
  cells_around(c, radius, c0, c1);
  const double r2 = radius * radius;
  for_each_in_cells(c0, c1, [&](std::int32_t at) {
    const double dx = x_[at] - c.x, dy = y_[at] - c.y, dz = z_[at] - c.z;
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 < r2) f(id_[at], d2);
  });
}

template <class Keep>
bool PointGrid::any_within(const Vec3& c, double radius, Keep&& keep) const {
  std::array<int, 3> c0, c1;
  cells_around(c, radius, c0, c1);
  const double r2 = radius * radius;
  return find_in_cells(c0, c1, [&](std::int32_t at) {
    const double dx = x_[at] - c.x, dy = y_[at] - c.y, dz = z_[at] - c.z;
    return dx * dx + dy * dy + dz * dz < r2 && keep(id_[at]);
  });
}

template <class F>
void PointGrid::for_each_run_near(const Vec3& lo, const Vec3& hi, double r2, F&& f) const {
  const double r = std::sqrt(r2);
  std::array<int, 3> c0, c1;
  for (int a = 0; a < 3; ++a) c0[a] = cell_of(lo[a] - r, a), c1[a] = cell_of(hi[a] + r, a);
  for (int k = c0[2]; k <= c1[2]; ++k) {
    const double gz = cell_gap(k, 2, lo.z, hi.z), rz = r2 - gz * gz;
    if (rz < 0) continue;
    for (int j = c0[1]; j <= c1[1]; ++j) {
      const double gy = cell_gap(j, 1, lo.y, hi.y), ry = rz - gy * gy;
      if (ry < 0) continue;
      const double rx = std::sqrt(ry);
      const std::size_t row = row_of(j, k);
      f(start_[row + cell_of(lo.x - rx, 0)], start_[row + cell_of(hi.x + rx, 0) + 1]);
    }
  }
}

}  // namespace cvt
