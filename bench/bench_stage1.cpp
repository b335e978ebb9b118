// Stage 1 on a real image (default: the liver): wall time per step and peak memory.
// Usage: bench_stage1 [IMAGE] [--threads N] [--repeat N]
//   --repeat runs stage 1 N times (one result alive at a time) and reports the minimum of each
//   step and of the total, for a machine shared with other work.
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <time.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "io/image_io.h"
#include "preprocess/preprocess.h"
#include "stage_timing.h"

namespace {

double process_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + double(t.tv_nsec) * 1e-9;
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = "data/liver.inr.gz";
  int threads = tbb::info::default_concurrency(), repeat = 1;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--threads") && a + 1 < argc)
      threads = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc)
      repeat = std::atoi(argv[++a]);
    else
      path = argv[a];
  }
  if (threads < 1 || repeat < 1) {
    std::fprintf(stderr, "%s: --threads and --repeat must be positive\n", argv[0]);
    return 2;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  const std::string load_before = load_average();
  using cvt::bench::print_row;
  auto t0 = std::chrono::steady_clock::now();
  const cvt::Image image = cvt::read_image(path);
  print_row("read " + path, cvt::bench::seconds_since(t0));

  std::vector<cvt::StepTime> best_steps;
  double best_total = 0, best_cpu = 0;
  cvt::PreprocessResult r;
  for (int run = 0; run < repeat; ++run) {
    r = cvt::PreprocessResult();
    const double cpu0 = process_cpu_seconds();
    t0 = std::chrono::steady_clock::now();
    r = cvt::preprocess(image, cvt::PreprocessOptions{});
    const double total = cvt::bench::seconds_since(t0), cpu = process_cpu_seconds() - cpu0;
    if (run == 0) {
      best_steps = r.steps;
      best_total = total;
      best_cpu = cpu;
      continue;
    }
    best_cpu = std::min(best_cpu, cpu);
    for (std::size_t s = 0; s < best_steps.size() && s < r.steps.size(); ++s)
      best_steps[s].wall_s = std::min(best_steps[s].wall_s, r.steps[s].wall_s);
    best_total = std::min(best_total, total);
  }
  for (const auto& s : best_steps) std::printf("  %-26s %9.3f s\n", s.name.c_str(), s.wall_s);
  print_row(repeat > 1 ? "stage 1 total (min of " + std::to_string(repeat) + ")" : "stage 1 total",
            best_total);
  std::printf("stage 1 CPU time (all threads, min) %.3f s\n", best_cpu);
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
  std::printf("load average before %s, after %s\n", load_before.c_str(), load_average().c_str());
  return 0;
}
