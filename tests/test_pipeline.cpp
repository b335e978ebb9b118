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

TEST(Pipeline, FidelityOnlyWhenAsked) {
  Pipeline pipe;
  pipe.set_image(torus_image());
  pipe.run_all();
  ASSERT_NE(pipe.quality(), nullptr);
  EXPECT_EQ(pipe.fidelity(), nullptr);
  const std::uint64_t before = pipe.generation(Stage::evaluate);
  pipe.set_evaluate_fidelity(true);  // only stage 7 becomes stale
  EXPECT_FALSE(pipe.is_stale(Stage::optimize));
  EXPECT_TRUE(pipe.is_stale(Stage::evaluate));
  pipe.run_all();
  ASSERT_NE(pipe.fidelity(), nullptr);
  EXPECT_GT(pipe.generation(Stage::evaluate), before);
  EXPECT_LT(pipe.fidelity()->distance.hausdorff_mm, 2.0);
  pipe.set_evaluate_fidelity(false);
  EXPECT_EQ(pipe.fidelity(), nullptr);
  EXPECT_NE(pipe.quality(), nullptr);
}

TEST(Pipeline, SingleRunFreesItsInputsAndGivesTheSameMesh) {
  Pipeline kept;
  kept.set_image(torus_image());
  kept.run_all();
  std::weak_ptr<const Image> watch;
  Pipeline once;
  {
    auto image = torus_image();
    watch = image;
    once.set_image(std::move(image), Pipeline::Run::once);
  }
  once.run_all();
  EXPECT_TRUE(watch.expired()) << "the image outlived stage 1";
  EXPECT_EQ(once.image(), nullptr);
  const PreprocessResult& pre = *once.preprocess();
  EXPECT_TRUE(pre.medial_axis.data.empty());
  EXPECT_TRUE(pre.lfs_mm.data.empty());
  EXPECT_TRUE(pre.nearest_opposite.data.empty());
  EXPECT_FALSE(pre.indicator.data.empty());  // stage 6 and the report still use these
  EXPECT_FALSE(pre.object.data.empty());
  EXPECT_FALSE(once.lloyd()->history().empty());  // its voxels went, its record stays
  const TetMesh &a = *kept.final_mesh(), &b = *once.final_mesh();
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.tets.size(), b.tets.size());
  for (std::size_t v = 0; v < a.vertices.size(); ++v)
    ASSERT_EQ(a.vertices[v].x, b.vertices[v].x) << v;
  EXPECT_EQ(a.tets, b.tets);
  // A stage that needs a freed input refuses to run again, with a message.
  Parameters p = once.parameters();
  p.r = 0.3;
  once.set_parameters(p);
  EXPECT_THROW(once.run_all(), InputError);
  p.lfs_min_mm = 1.5;
  once.set_parameters(p);
  EXPECT_THROW(once.run_all(), InputError);
}

// Stage 2 caps lfs at its median over the boundary unless told otherwise, which only adds
// surface samples: the interior spacing stays that of the uncapped samples, also where the
// capped radii fall below the voxel and every boundary voxel becomes a sample.
TEST(Pipeline, SurfaceLfsCapIsTheMedianAndLeavesTheInteriorSpacing) {
  auto stage2 = [](double cap) {
    auto pipe = std::make_unique<Pipeline>();
    pipe->set_image(torus_image());
    Parameters p;
    p.surface_lfs_max_mm = cap;
    pipe->set_parameters(p);
    pipe->run_through(Stage::surface);
    return pipe;
  };
  const auto automatic = stage2(0), off = stage2(1000), fine = stage2(0.01), finer = stage2(0.02);
  const double median = median_boundary_lfs_mm(*automatic->preprocess());
  EXPECT_GT(median, 0);
  EXPECT_EQ(automatic->surface()->surface_lfs_max_mm, median);
  // The torus' lfs varies (its inner rim is closer to the medial circle), so the cap bites.
  EXPECT_GT(automatic->surface()->world.size(), off->surface()->world.size());
  EXPECT_EQ(fine->surface()->world.size(), automatic->preprocess()->boundary.size());
  EXPECT_EQ(fine->default_interior_spacing_mm(), finer->default_interior_spacing_mm());
  EXPECT_NEAR(fine->default_interior_spacing_mm(), off->default_interior_spacing_mm(),
              0.01 * off->default_interior_spacing_mm());
  EXPECT_NEAR(automatic->default_interior_spacing_mm(), off->default_interior_spacing_mm(),
              0.01 * off->default_interior_spacing_mm());
}
