// PointGrid queries against brute force on seeded random points, some outside the grid's box
// (they fall into the border cells), and the nearest-site owners built on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "base/point_grid.h"
#include "sampling/nearest_site.h"

using cvt::PointGrid;
using cvt::Vec3;

namespace {

std::vector<Vec3> random_points(std::size_t n, const Vec3& lo, const Vec3& hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> points(n);
  for (Vec3& p : points)
    for (int a = 0; a < 3; ++a) p[a] = lo[a] + (hi[a] - lo[a]) * u(rng);
  return points;
}

double box_distance2(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double g = std::max(0.0, std::max(lo[a] - p[a], p[a] - hi[a]));
    d2 += g * g;
  }
  return d2;
}

}  // namespace

TEST(PointGrid, WithinRadiusMatchesBruteForce) {
  // The box [0, 10]³ and points in [−2, 12]³: the outer ones land in the border cells.
  const std::vector<Vec3> points = random_points(2000, {-2, -2, -2}, {12, 12, 12}, 7);
  const std::vector<Vec3> queries = random_points(200, {-3, -3, -3}, {13, 13, 13}, 8);
  for (double cell : {0.0, 0.7, 3.0}) {
    const PointGrid grid(points, {0, 0, 0}, {10, 10, 10}, cell);
    ASSERT_EQ(grid.size(), points.size());
    std::mt19937_64 rng(9);
    for (const Vec3& c : queries) {
      const double radius = std::uniform_real_distribution<double>(0.1, 2.5)(rng);
      std::vector<std::pair<int, double>> found, expected;
      grid.for_each_within(c, radius, [&](std::int32_t i, double d2) { found.push_back({i, d2}); });
      for (std::size_t i = 0; i < points.size(); ++i) {
        const double d2 = cvt::squared_distance(points[i], c);
        if (d2 < radius * radius) expected.push_back({int(i), d2});
      }
      std::sort(found.begin(), found.end());
      ASSERT_EQ(found.size(), expected.size()) << "cell " << cell;
      for (std::size_t k = 0; k < found.size(); ++k) {
        EXPECT_EQ(found[k].first, expected[k].first);
        EXPECT_EQ(found[k].second, expected[k].second);  // bit for bit
      }
      EXPECT_EQ(grid.any_within(c, radius), !expected.empty());
      // With a filter: only the points of even index count.
      const bool even = std::any_of(expected.begin(), expected.end(),
                                    [](const auto& e) { return e.first % 2 == 0; });
      EXPECT_EQ(grid.any_within(c, radius, [](std::int32_t i) { return i % 2 == 0; }), even);
    }
  }
}

TEST(PointGrid, VisitsCellsInOrderAndEachCellInInputOrder) {
  const std::vector<Vec3> points = random_points(500, {0, 0, 0}, {5, 5, 5}, 3);
  const PointGrid grid(points, 1.0);
  auto cell_key = [&](const Vec3& p) {
    return (std::int64_t(grid.cell_of(p.z, 2)) * grid.cells()[1] + grid.cell_of(p.y, 1)) *
               grid.cells()[0] +
           grid.cell_of(p.x, 0);
  };
  std::vector<std::int32_t> order;
  grid.for_each_within({2.5, 2.5, 2.5}, 100.0, [&](std::int32_t i, double) { order.push_back(i); });
  ASSERT_EQ(order.size(), points.size());
  for (std::size_t k = 1; k < order.size(); ++k) {
    const auto a = cell_key(points[order[k - 1]]), b = cell_key(points[order[k]]);
    EXPECT_TRUE(a < b || (a == b && order[k - 1] < order[k]));
  }
}

TEST(PointGrid, RunsNearBoxHoldEveryPointWithinTheDistance) {
  const std::vector<Vec3> points = random_points(3000, {-1, -1, -1}, {21, 11, 6}, 11);
  const PointGrid grid(points, {0, 0, 0}, {20, 10, 5}, 1.3);
  const std::vector<Vec3> corners = random_points(100, {-2, -2, -2}, {22, 12, 7}, 12);
  std::mt19937_64 rng(13);
  for (std::size_t q = 0; q + 1 < corners.size(); q += 2) {
    Vec3 lo = corners[q], hi = corners[q + 1];
    for (int a = 0; a < 3; ++a)
      if (lo[a] > hi[a]) std::swap(lo[a], hi[a]);
    const double r = std::uniform_real_distribution<double>(0.0, 3.0)(rng);
    std::vector<char> seen(points.size(), 0);
    grid.for_each_run_near(lo, hi, r * r, [&](std::int32_t begin, std::int32_t end) {
      for (std::int32_t at = begin; at < end; ++at) {
        const std::int32_t i = grid.index()[at];
        EXPECT_EQ(grid.x()[at], points[i].x);
        EXPECT_EQ(grid.y()[at], points[i].y);
        EXPECT_EQ(grid.z()[at], points[i].z);
        seen[i] = 1;
      }
    });
    for (std::size_t i = 0; i < points.size(); ++i)
      if (box_distance2(points[i], lo, hi) <= r * r) EXPECT_TRUE(seen[i]) << "point " << i;
  }
}

TEST(PointGrid, DegenerateInputs) {
  const PointGrid empty(std::vector<Vec3>{}, 1.0);
  EXPECT_EQ(empty.size(), 0u);
  EXPECT_FALSE(empty.any_within({0, 0, 0}, 10.0));
  // Points on a line: the flat box must not turn into a huge number of tiny cells.
  std::vector<Vec3> line;
  for (int i = 0; i < 100; ++i) line.push_back({0.1 * i, 0, 0});
  const PointGrid flat(line, 0.0);
  const auto& n = flat.cells();
  EXPECT_LE(double(n[0]) * n[1] * n[2], 8.0 * (64 * 100 + 64));
  EXPECT_TRUE(flat.any_within({5.0, 0, 0}, 0.01));
  EXPECT_FALSE(flat.any_within({5.05, 0, 0}, 0.04));
  // Coordinates far outside the box, and NaN, clamp to the border cells.
  EXPECT_EQ(flat.cell_of(-1e300, 0), 0);
  EXPECT_EQ(flat.cell_of(1e300, 0), n[0] - 1);
  EXPECT_EQ(flat.cell_of(std::numeric_limits<double>::quiet_NaN(), 0), 0);
}

TEST(NearestSite, OwnersAreExactlyNearest) {
  cvt::Grid g;
  g.dims = {30, 25, 12};
  g.spacing = {0.8, 0.8, 2.0};
  const std::vector<Vec3> sites = random_points(150, {-1, -1, -1}, {24, 20, 23}, 21);
  std::vector<std::int32_t> voxels;
  for (std::size_t v = 0; v < g.voxel_count(); v += 7) voxels.push_back(std::int32_t(v));
  const std::vector<std::int32_t> owners = cvt::nearest_site_owners(g, sites, voxels);
  ASSERT_EQ(owners.size(), voxels.size());
  for (std::size_t k = 0; k < voxels.size(); ++k) {
    const auto ijk = g.ijk(std::size_t(voxels[k]));
    const Vec3 p = g.index_to_local({double(ijk[0]), double(ijk[1]), double(ijk[2])});
    double best = std::numeric_limits<double>::infinity();
    for (const Vec3& s : sites) best = std::min(best, cvt::squared_distance(p, s));
    ASSERT_GE(owners[k], 0);
    EXPECT_NEAR(cvt::squared_distance(p, sites[std::size_t(owners[k])]), best, 1e-9);
  }
}
