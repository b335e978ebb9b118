#include "base/point_grid.h"

#include <algorithm>
#include <string>

#include "base/errors.h"

namespace cvt {

namespace {

Vec3 bounding_lo(const std::vector<Vec3>& points) {
  Vec3 lo = points.empty() ? Vec3{} : points[0];
  for (const Vec3& p : points)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]);
  return lo;
}

Vec3 bounding_hi(const std::vector<Vec3>& points) {
  Vec3 hi = points.empty() ? Vec3{} : points[0];
  for (const Vec3& p : points)
    for (int a = 0; a < 3; ++a) hi[a] = std::max(hi[a], p[a]);
  return hi;
}

}  // namespace

PointGrid::PointGrid(const std::vector<Vec3>& points, double cell_mm)
    : PointGrid(points, bounding_lo(points), bounding_hi(points), cell_mm) {}

PointGrid::PointGrid(const std::vector<Vec3>& points, const Vec3& lo, const Vec3& hi,
                     double cell_mm)
    : lo_(lo) {
  if (points.size() > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw InputError("point grid: " + std::to_string(points.size()) + " points are too many");
  const Vec3 extent = hi - lo;
  const double volume =
      std::max(extent.x, 1e-9) * std::max(extent.y, 1e-9) * std::max(extent.z, 1e-9);
  const double n = double(points.size());
  cell_ =
      std::max(cell_mm > 0 ? cell_mm : std::cbrt(volume / n), std::cbrt(volume / (64 * n + 64)));
  // A box thinner than a cell along some axis has one cell there, so the volume above
  // under-counts the cells; coarser cells keep their number bounded.
  std::array<double, 3> along;
  for (;;) {
    double cells = 1;
    for (int a = 0; a < 3; ++a) {
      along[a] = std::ceil(extent[a] / cell_);
      if (!(along[a] > 1)) along[a] = 1;
      cells *= along[a];
    }
    if (cells <= 8 * (64 * n + 64)) break;
    cell_ *= 2;
  }
  for (int a = 0; a < 3; ++a) n_[a] = int(along[a]);
  // Counting sort by cell: stable, so each cell keeps the input order.
  std::vector<std::size_t> cell_at(points.size());
  start_.assign(std::size_t(n_[0]) * n_[1] * n_[2] + 1, 0);
  for (std::size_t s = 0; s < points.size(); ++s) {
    const Vec3& p = points[s];
    cell_at[s] = row_of(cell_of(p.y, 1), cell_of(p.z, 2)) + cell_of(p.x, 0);
    ++start_[cell_at[s] + 1];
  }
  for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
  std::vector<std::int32_t> fill(start_.begin(), start_.end() - 1);
  id_.resize(points.size());
  x_.resize(points.size()), y_.resize(points.size()), z_.resize(points.size());
  for (std::size_t s = 0; s < points.size(); ++s) {
    const std::int32_t at = fill[cell_at[s]]++;
    id_[at] = std::int32_t(s);
    x_[at] = points[s].x, y_[at] = points[s].y, z_[at] = points[s].z;
  }
}

bool PointGrid::any_within(const Vec3& c, double radius) const {
  return any_within(c, radius, [](std::int32_t) { return true; });
}

}  // namespace cvt
