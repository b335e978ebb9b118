// Stage 1 on a real image (default: the liver): wall time per step and peak memory.
// Usage: bench_stage1 [IMAGE] [--threads N]
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>

#include <tbb/global_control.h>
#include <tbb/info.h>

#include "image_io.h"
#include "preprocess.h"
#include "stage_timing.h"

int main(int argc, char** argv) {
  std::string path = "data/liver.inr.gz";
  int threads = tbb::info::default_concurrency();
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--threads") && a + 1 < argc) threads = std::atoi(argv[++a]);
    else path = argv[a];
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  using cvt::bench::print_row;
  auto t0 = std::chrono::steady_clock::now();
  const cvt::Image image = cvt::read_image(path);
  print_row("read " + path, cvt::bench::seconds_since(t0));

  t0 = std::chrono::steady_clock::now();
  const cvt::PreprocessResult r = cvt::preprocess(image, cvt::PreprocessOptions{});
  const double total = cvt::bench::seconds_since(t0);
  for (const auto& s : r.steps) std::printf("  %-26s %9.3f s\n", s.name.c_str(), s.wall_s);
  print_row("stage 1 total", total);
  const auto& g = r.object.grid;
  std::printf("threads %d, crop %d x %d x %d = %.1f M voxels, boundary voxels %zu\n", threads,
              g.dims[0], g.dims[1], g.dims[2], double(g.voxel_count()) / 1e6, r.boundary.size());
  std::printf("medial voxels: inner %td, outer %td; lfs clamp [%.2f, %.2f] mm\n",
              std::count(r.medial_axis.data.begin(), r.medial_axis.data.end(), 1),
              std::count(r.medial_axis.data.begin(), r.medial_axis.data.end(), 2),
              r.lfs_bounds.min_mm, r.lfs_bounds.max_mm);
  std::printf("clean-up: %d components, %d removed (%zu voxels), %d cavities filled (%zu voxels)\n",
              r.cleanup.components, r.cleanup.components_removed, r.cleanup.voxels_removed,
              r.cleanup.cavities_filled, r.cleanup.voxels_filled);
  return 0;
}
