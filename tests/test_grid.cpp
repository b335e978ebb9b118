#include <gtest/gtest.h>

#include <cmath>

#include "base/grid.h"

using cvt::Grid;
using cvt::Vec3;

TEST(Grid, IndexWorldRoundTripWithRotationAndAnisotropy) {
  Grid g;
  g.dims = {10, 20, 30};
  g.spacing = {0.5, 0.7, 1.3};
  g.origin = {-12.0, 4.5, 100.25};
  const double c = std::cos(0.3), s = std::sin(0.3);
  g.direction = {c, -s, 0, s, c, 0, 0, 0, 1};
  const Vec3 idx{3.25, 7.5, 11.0};
  const Vec3 w = g.index_to_world(idx);
  const Vec3 back = g.world_to_index(w);
  EXPECT_NEAR(back.x, idx.x, 1e-12);
  EXPECT_NEAR(back.y, idx.y, 1e-12);
  EXPECT_NEAR(back.z, idx.z, 1e-12);
  // Distances in world space equal distances in the local (spacing-scaled) frame.
  const Vec3 a{1, 2, 3}, b{4, 0, 9};
  EXPECT_NEAR(cvt::distance(g.index_to_world(a), g.index_to_world(b)),
              cvt::distance(g.index_to_local(a), g.index_to_local(b)), 1e-12);
  // Voxel (1,0,0) lies one spacing along the first direction column.
  const Vec3 step = g.index_to_world({1, 0, 0}) - g.origin;
  EXPECT_NEAR(step.x, 0.5 * c, 1e-12);
  EXPECT_NEAR(step.y, 0.5 * s, 1e-12);
}

TEST(Grid, SubGridKeepsWorldPositions) {
  Grid g;
  g.dims = {8, 8, 8};
  g.spacing = {1, 2, 3};
  g.origin = {5, 6, 7};
  Grid sub = g.sub_grid({-2, 3, 1}, {4, 4, 4});
  const Vec3 w_sub = sub.index_to_world({1, 1, 1});
  const Vec3 w = g.index_to_world({-1, 4, 2});
  EXPECT_NEAR(cvt::distance(w_sub, w), 0.0, 1e-12);
  EXPECT_EQ(sub.linear(1, 2, 3), std::size_t(1 + 4 * (2 + 4 * 3)));
  auto ijk = sub.ijk(sub.linear(1, 2, 3));
  EXPECT_EQ(ijk[0], 1);
  EXPECT_EQ(ijk[1], 2);
  EXPECT_EQ(ijk[2], 3);
}
