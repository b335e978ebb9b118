// --vertices N: the sizing rule on its own, and the pipeline reaching about N vertices on
// phantoms of two shapes.
#include <gtest/gtest.h>

#include <cmath>

#include "phantoms.h"
#include "pipeline/pipeline.h"
#include <nlohmann/json.hpp>

#include "pipeline/run_report.h"
#include "pipeline/vertex_budget.h"

using namespace cvt;

TEST(VertexBudget, RScalesWithTheSquareRootOfTheCount) {
  // S + n = 40,000 at r = 0.4: a quarter of that count needs twice the r.
  EXPECT_NEAR(r_for_budget(0.4, 10000, 30000, 10000), 0.8, 1e-12);
  EXPECT_NEAR(r_for_budget(0.4, 10000, 30000, 40000), 0.4, 1e-12);
  EXPECT_LT(r_for_budget(0.4, 10000, 30000, 4000000), 0.05);  // clamped, never 0
  EXPECT_GT(r_for_budget(0.4, 10000, 30000, 4000000), 0.0);
  EXPECT_LT(r_for_budget(0.4, 10000, 30000, 10), 1.0);
}

TEST(VertexBudget, InteriorPointsLeaveTheTargetAfterShallowRemoval) {
  // A shallow share of 30 % at 20,000 sites, falling as n^(−1/3).
  const std::int64_t target = 50000, surface = 12000, probe = 20000;
  const double share = 0.3;
  const std::int64_t n = interior_points_for_budget(target, surface, probe, share);
  const double kept = double(n) * (1.0 - share * std::cbrt(double(probe) / double(n)));
  EXPECT_NEAR(kept, double(target - surface), 1.0);
  EXPECT_GT(n, target - surface);
  // No shallow sites: exactly what is left; no room left: one site.
  EXPECT_EQ(interior_points_for_budget(target, surface, probe, 0.0), target - surface);
  EXPECT_EQ(interior_points_for_budget(1000, 5000, probe, share), 1);
}

// The mesh has about the vertices asked for (within 10 %), for a smaller and a larger budget
// than the default's, and the run's r and interior points are the budget's.
TEST(VertexBudget, PipelineReachesTheTarget) {
  for (const Phantom& p : {torus_phantom({1, 2, 3}, 10.0, 4.0), sphere_phantom({0, 0, 0}, 12.0)}) {
    auto image = std::make_shared<const Image>(
        rasterize(p, grid_around(p, {0.8, 0.9, 1.0}, rotation_matrix({1, 1, 0}, 0.3))));
    for (const std::int64_t target : {3000, 12000}) {
      Pipeline pipe;
      Parameters params;
      params.target_vertices = target;
      pipe.set_parameters(params);
      pipe.set_image(image);
      pipe.run_all();
      const double got = double(pipe.final_mesh()->vertices.size());
      EXPECT_NEAR(got / double(target), 1.0, 0.1) << target;
      const Parameters sized = pipe.sized_parameters();
      EXPECT_NE(sized.r, params.r);
      EXPECT_GT(sized.interior_points, 0);
      EXPECT_TRUE(pipe.quality()->validity.valid);
      EXPECT_EQ(run_report(pipe)["vertex_budget"]["interior_points"], sized.interior_points);
    }
  }
}
