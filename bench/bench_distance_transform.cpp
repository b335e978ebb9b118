// EDT + feature transform on a CT-sized volume, against a plain memcpy of a float volume of the
// same size. Every benchmark reports the same items (voxels) and bytes (4 per voxel) per
// iteration, so the ratio of their rates (or real times) reads directly as "× memcpy".
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cstdint>
#include <cstring>

#include "distance_transform.h"

namespace {

// 438 × 353 × 165 ≈ 25.5 M voxels at CT spacing; features are the complement of a large
// ellipsoid, so most of the volume has a distance to compute and many lines have no feature
// inside the ellipsoid.
const cvt::Mask& ct_sized_mask() {
  static const cvt::Mask mask = [] {
    cvt::Grid g;
    g.dims = {438, 353, 165};
    g.spacing = {0.617, 0.617, 1.333};
    cvt::Mask m(g);
    const double cx = 219, cy = 176, cz = 82, rx = 200, ry = 160, rz = 75;
    for (int k = 0; k < g.dims[2]; ++k)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int i = 0; i < g.dims[0]; ++i) {
          const double x = (i - cx) / rx, y = (j - cy) / ry, z = (k - cz) / rz;
          m.at(i, j, k) = x * x + y * y + z * z > 1.0 ? 1 : 0;
        }
    return m;
  }();
  return mask;
}

void set_counters(benchmark::State& state, std::size_t voxels) {
  state.SetItemsProcessed(std::int64_t(state.iterations() * voxels));
  state.SetBytesProcessed(std::int64_t(state.iterations() * voxels * sizeof(float)));
}

// Arg: thread count.
void BM_FeatureTransform(benchmark::State& state) {
  const cvt::Mask& mask = ct_sized_mask();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  for (auto _ : state) {
    cvt::FeatureTransform ft = cvt::compute_feature_transform(mask, true);
    benchmark::DoNotOptimize(ft.nearest.data.data());
  }
  set_counters(state, mask.size());
}

void BM_DistanceOnly(benchmark::State& state) {
  const cvt::Mask& mask = ct_sized_mask();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  for (auto _ : state) {
    cvt::FeatureTransform ft = cvt::compute_feature_transform(mask, false);
    benchmark::DoNotOptimize(ft.squared_distance_mm2.data.data());
  }
  set_counters(state, mask.size());
}

// The reference: one memcpy of a float volume into an already-touched buffer.
void BM_MemcpyFloatVolume(benchmark::State& state) {
  const cvt::Grid& g = ct_sized_mask().grid;
  const cvt::Volume<float> src(g, 1.0f);
  cvt::Volume<float> dst(g, 0.0f);
  for (auto _ : state) {
    std::memcpy(dst.data.data(), src.data.data(), src.size() * sizeof(float));
    benchmark::ClobberMemory();
  }
  set_counters(state, src.size());
}

// What the EDT pays before computing anything: fresh (page-faulting, zero-filled) output volumes.
void BM_AllocateOutputs(benchmark::State& state) {
  const cvt::Grid& g = ct_sized_mask().grid;
  const bool nearest = state.range(0) != 0;
  for (auto _ : state) {
    cvt::Volume<float> distance(g);
    benchmark::DoNotOptimize(distance.data.data());
    if (nearest) {
      cvt::Volume<std::int32_t> index(g);
      benchmark::DoNotOptimize(index.data.data());
    }
  }
  set_counters(state, g.voxel_count());
}

BENCHMARK(BM_FeatureTransform)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DistanceOnly)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MemcpyFloatVolume)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_AllocateOutputs)
    ->ArgName("nearest")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
