// The Pipeline both programs drive: stale tracking, stepping and a whole run on a phantom.
#include <gtest/gtest.h>

#include <atomic>
#include <exception>
#include <type_traits>

#include "base/errors.h"
#include "phantoms.h"
#include "pipeline/pipeline.h"

using namespace cvt;

namespace {

std::shared_ptr<const Image> torus_image() {
  const Phantom p = torus_phantom({4, -3, 2}, 9.0, 3.5);
  return std::make_shared<Image>(rasterize(p, grid_around(p, {0.7, 0.8, 1.0}, rotation_matrix({1, 0, 1}, 0.3))));
}

}  // namespace

TEST(Pipeline, ParameterChangesMarkThatStageAndDownstreamStale) {
  Pipeline pipe;
  pipe.set_image(torus_image());
  pipe.run_all();
  for (int s = 0; s < kStageCount; ++s) EXPECT_FALSE(pipe.is_stale(Stage(s))) << stage_name(Stage(s));
  ASSERT_NE(pipe.mesh(), nullptr);
  EXPECT_GT(pipe.mesh()->mesh.tets.size(), 100u);

  Parameters p = pipe.parameters();
  p.seed = 99;  // only the CVT stage and what follows depend on the seed
  pipe.set_parameters(p);
  EXPECT_FALSE(pipe.is_stale(Stage::preprocess));
  EXPECT_FALSE(pipe.is_stale(Stage::surface));
  EXPECT_TRUE(pipe.is_stale(Stage::cvt));
  EXPECT_TRUE(pipe.is_stale(Stage::mesh));
  EXPECT_EQ(pipe.mesh(), nullptr);

  p.r = 0.3;
  pipe.set_parameters(p);
  EXPECT_FALSE(pipe.is_stale(Stage::preprocess));
  EXPECT_TRUE(pipe.is_stale(Stage::surface));
  p.lfs_min_mm = 1.5;
  pipe.set_parameters(p);
  EXPECT_TRUE(pipe.is_stale(Stage::preprocess));
  // An unchanged set keeps everything.
  pipe.run_all();
  pipe.set_parameters(p);
  EXPECT_FALSE(pipe.is_stale(Stage::mesh));
  // Out-of-range values are refused and change nothing.
  Parameters bad = p;
  bad.r = 2;
  EXPECT_THROW(pipe.set_parameters(bad), InputError);
  EXPECT_EQ(pipe.parameters().r, 0.3);
  EXPECT_FALSE(pipe.is_stale(Stage::mesh));
}

TEST(Pipeline, LloydStepsThenRunAllContinues) {
  Pipeline pipe;
  pipe.set_image(torus_image());
  EXPECT_EQ(pipe.step_lloyd(1), 1);
  ASSERT_NE(pipe.lloyd(), nullptr);
  EXPECT_EQ(pipe.lloyd()->history().size(), 1u);
  EXPECT_EQ(pipe.step_lloyd(3), 3);
  EXPECT_EQ(pipe.lloyd()->history().size(), 4u);
  EXPECT_TRUE(pipe.is_stale(Stage::shallow));
  pipe.run_all();
  EXPECT_GE(pipe.lloyd()->history().size(), 4u);
  EXPECT_FALSE(pipe.is_stale(Stage::mesh));
}

TEST(Pipeline, CancellationStopsARun) {
  Pipeline pipe;
  pipe.set_image(torus_image());
  std::atomic<bool> cancel{true};
  Progress progress;
  progress.cancel = &cancel;
  EXPECT_THROW(pipe.run_all(progress), Cancelled);
  EXPECT_TRUE(pipe.is_stale(Stage::preprocess));
  // A cancel is no error: a handler for std::exception (an error message) lets it pass.
  static_assert(!std::is_base_of_v<std::exception, Cancelled>);
  cancel = false;
  pipe.run_all(progress);
  EXPECT_FALSE(pipe.is_stale(Stage::mesh));
}

TEST(Pipeline, NoImageIsAClearError) {
  Pipeline pipe;
  EXPECT_THROW(pipe.run_all(), InputError);
}
