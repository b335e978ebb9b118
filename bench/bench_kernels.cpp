// The hot kernels of the pipeline on the real liver (all non-zero labels, default parameters),
// each with its throughput:
//   EDT + feature transform of the cropped object   items = voxels
//   surface sampling (stage 2, Algorithm 1)         items = boundary voxels F
//   Delaunay + pole removal (stage 5)               items = samples |B| + |I|
//   quality (Table I measures, dihedrals, validity) items = tets
// One Lloyd iteration is in bench_lloyd (items = sites). The image: $CVTMESH_LIVER, else
// data/liver.inr.gz relative to the working directory. Arg of each benchmark: thread count.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "fields/distance_transform.h"
#include "io/image_io.h"
#include "meshing/mesh_generation.h"
#include "pipeline/pipeline.h"
#include "evaluate/quality.h"
#include "fields/smoothing.h"
#include "sampling/surface_sampling.h"

namespace {

// The liver run through stage 6 once with default parameters; every benchmark reads from it.
const cvt::Pipeline& liver() {
  static const std::unique_ptr<cvt::Pipeline> pipeline = [] {
    const char* env = std::getenv("CVTMESH_LIVER");
    const std::string path = env ? env : "data/liver.inr.gz";
    auto p = std::make_unique<cvt::Pipeline>();
    p->set_image(std::make_shared<const cvt::Image>(cvt::read_image(path)));
    p->run_through(cvt::Stage::optimize);
    const cvt::Grid& g = p->preprocess()->object.grid;
    std::fprintf(stderr, "%s: crop %d x %d x %d, |F| %zu, |B| %zu, |I| %zu, %zu tets\n",
                 path.c_str(), g.dims[0], g.dims[1], g.dims[2], p->preprocess()->boundary.size(),
                 p->surface()->world.size(), p->shallow()->kept_world.size(),
                 p->final_mesh()->tets.size());
    return p;
  }();
  return *pipeline;
}

// Occupancy from the smoothed indicator, as the pipeline's stage 5 uses it.
cvt::OccupancyFunction occupancy(const cvt::Volume<float>& indicator) {
  return [&indicator](const cvt::Vec3& world) {
    const cvt::Vec3 idx = indicator.grid.world_to_index(world);
    for (int a = 0; a < 3; ++a)
      if (!(idx[a] >= 0 && idx[a] <= indicator.grid.dims[a] - 1)) return 0.0;
    return double(cvt::sample_trilinear(indicator, idx));
  };
}

void BM_FeatureTransform(benchmark::State& state) {
  const cvt::Mask& object = liver().preprocess()->object;
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  for (auto _ : state) {
    cvt::FeatureTransform ft = cvt::compute_feature_transform(object, true);
    benchmark::DoNotOptimize(ft.nearest.data.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(object.size()));
  state.SetBytesProcessed(state.iterations() * std::int64_t(object.size() * sizeof(float)));
}

void BM_SurfaceSampling(benchmark::State& state) {
  const cvt::Pipeline& p = liver();
  const cvt::SurfaceSamplingOptions options = cvt::surface_options(p.parameters(), *p.preprocess());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  std::size_t samples = 0;
  for (auto _ : state) {
    const cvt::SurfaceSamples s = cvt::sample_surface(*p.preprocess(), options);
    samples = s.world.size();
    benchmark::DoNotOptimize(s.world.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(p.preprocess()->boundary.size()));
  state.counters["samples"] = double(samples);
}

void BM_DelaunayAndPoleRemoval(benchmark::State& state) {
  const cvt::Pipeline& p = liver();
  const std::vector<cvt::Vec3>& b = p.surface()->world;
  const std::vector<cvt::Vec3>& i = p.shallow()->kept_world;
  const cvt::OccupancyFunction occ = occupancy(p.preprocess()->indicator);
  const cvt::MeshGenerationOptions options = cvt::mesh_options(p.parameters());
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  std::size_t tets = 0;
  for (auto _ : state) {
    const cvt::MeshGenerationResult r = cvt::build_delaunay_mesh(b, i, occ, options);
    tets = r.mesh.tets.size();
    benchmark::DoNotOptimize(r.mesh.tets.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(b.size() + i.size()));
  state.counters["tets"] = double(tets);
}

void BM_Quality(benchmark::State& state) {
  const cvt::TetMesh& mesh = *liver().final_mesh();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, state.range(0));
  for (auto _ : state) {
    const cvt::QualityReport q = cvt::compute_quality(mesh);
    benchmark::DoNotOptimize(q.dihedral.min_deg);
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(mesh.tets.size()));
}

BENCHMARK(BM_FeatureTransform)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_SurfaceSampling)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_DelaunayAndPoleRemoval)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Quality)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
