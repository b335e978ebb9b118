// One Lloyd iteration (exact discrete Voronoi assignment + centroids) on the real liver at ~50k
// sites, against the thread count; plus the label volume and the owners of F (stage 4).
// The image: $CVTMESH_LIVER, else data/liver.inr.gz relative to the working directory.
// Items/s = sites per second.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "sampling/cvt_sampling.h"
#include "io/image_io.h"
#include "preprocess/preprocess.h"
#include "sampling/shallow_points.h"

namespace {

const cvt::PreprocessResult& liver() {
  static const cvt::PreprocessResult pre = [] {
    const char* env = std::getenv("CVTMESH_LIVER");
    const std::string path = env ? env : "data/liver.inr.gz";
    const cvt::PreprocessResult r = cvt::preprocess(cvt::read_image(path), {});
    std::size_t inside = 0;
    for (unsigned char v : r.object.data) inside += v;
    std::fprintf(stderr, "%s: crop %d x %d x %d, %zu object voxels\n", path.c_str(),
                 r.object.grid.dims[0], r.object.grid.dims[1], r.object.grid.dims[2], inside);
    return r;
  }();
  return pre;
}

// A stepper a few iterations in, so the timed iterations see realistic (not random) regions.
cvt::LloydStepper& stepper(std::int64_t sites) {
  static std::unique_ptr<cvt::LloydStepper> st;
  if (!st || st->resolved().sites != sites) {
    cvt::CvtOptions o;
    o.interior_points = sites;
    o.epsilon_mm = 1e-300;  // never "converged": every run is a full iteration
    st = std::make_unique<cvt::LloydStepper>(liver(), o);
    st->run(3);
  }
  return *st;
}

// Args: sites, threads.
void BM_LloydIteration(benchmark::State& state) {
  cvt::LloydStepper& st = stepper(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(1));
  for (auto _ : state) benchmark::DoNotOptimize(st.step().energy);
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_ComputeLabels(benchmark::State& state) {
  cvt::LloydStepper& st = stepper(state.range(0));
  cvt::Volume<std::int32_t> labels;
  for (auto _ : state) {
    st.compute_labels(labels);
    benchmark::DoNotOptimize(labels.data.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// Stage 4 as the pipeline runs it: owners of the boundary voxels F only.
void BM_RemoveShallowPoints(benchmark::State& state) {
  cvt::LloydStepper& st = stepper(state.range(0));
  const cvt::PreprocessResult& pre = liver();
  for (auto _ : state) {
    const cvt::ShallowResult r =
        cvt::remove_shallow_points(pre.object.grid, st.sites_world(), pre.boundary);
    benchmark::DoNotOptimize(r.kept_world.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(pre.boundary.size()));
}

BENCHMARK(BM_LloydIteration)
    ->ArgNames({"sites", "threads"})
    ->Args({50000, 1})
    ->Args({50000, 2})
    ->Args({10000, 2})
    ->Args({200000, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_ComputeLabels)
    ->ArgName("sites")
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_RemoveShallowPoints)
    ->ArgName("sites")
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
