// EDT with and without the feature transform on a CT-sized volume, against a plain memcpy of a
// float volume of the same size, all in one process. Rounds interleave the cases (so a load
// change on a shared machine hits all of them alike); the table gives the minimum and median
// wall time over rounds and the ratio of minima to the warm memcpy.
// Usage: bench_distance_transform [--rounds N] [--threads N] [--only CASE]
//   --only runs one case once per round (e.g. under valgrind --tool=callgrind).
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "fields/distance_transform.h"

namespace {

// 438 × 353 × 165 ≈ 25.5 M voxels (the liver image's grid) at CT spacing; features are the
// complement of a large ellipsoid, so most of the volume has a distance to compute and many
// lines have no feature inside the ellipsoid.
cvt::Mask ct_sized_mask() {
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
}

// The EDT's memory traffic without its arithmetic: one sweep that reads the mask and writes the
// outputs row by row (passes i and j), then one that reads and rewrites them through 32-wide
// tiles of z-columns, as pass k does. Its time is the floor of this two-sweep layout.
template <std::size_t kBytes>
void copy_tile(float* value, std::int32_t* index, std::size_t first, std::size_t slice, int nz,
               float* tv, std::int32_t* ti) {
  constexpr std::size_t kWidth = kBytes / sizeof(float);
  for (int k = 0; k < nz; ++k) {
    std::memcpy(tv + k * kWidth, value + first + k * slice, kBytes);
    if (index) std::memcpy(ti + k * kWidth, index + first + k * slice, kBytes);
  }
  for (std::size_t k = 0; k < nz * kWidth; ++k) tv[k] += 1.0f;
  for (int k = 0; k < nz; ++k) {
    std::memcpy(value + first + k * slice, tv + k * kWidth, kBytes);
    if (index) std::memcpy(index + first + k * slice, ti + k * kWidth, kBytes);
  }
}

void traffic_only(const cvt::Mask& mask, float* value, std::int32_t* index) {
  const auto [nx, ny, nz] = mask.grid.dims;
  const std::size_t slice = std::size_t(nx) * ny;
  tbb::parallel_for(0, nz, [&](int k) {
    for (std::size_t v = k * slice; v < (k + 1) * slice; ++v) {
      value[v] = mask.data[v] ? 0.0f : 1.0f;
      if (index) index[v] = std::int32_t(v);
    }
  });
  constexpr int kWidth = 32;
  const int tiles = (nx + kWidth - 1) / kWidth;
  tbb::parallel_for(tbb::blocked_range<int>(0, ny * tiles), [&](const tbb::blocked_range<int>& r) {
    std::vector<float> tv(std::size_t(kWidth) * nz);
    std::vector<std::int32_t> ti(tv.size());
    for (int t = r.begin(); t < r.end(); ++t) {
      const std::size_t first = std::size_t(t / tiles) * nx + (t % tiles) * kWidth;
      const std::size_t bytes = std::min(kWidth, nx - (t % tiles) * kWidth) * sizeof(float);
      if (bytes == kWidth * sizeof(float)) {  // compile-time size: inlined moves, no calls
        copy_tile<kWidth * sizeof(float)>(value, index, first, slice, nz, tv.data(), ti.data());
        continue;
      }
      for (int k = 0; k < nz; ++k) {
        std::memcpy(&tv[k * kWidth], value + first + k * slice, bytes);
        if (index) std::memcpy(&ti[k * kWidth], index + first + k * slice, bytes);
      }
      for (float& x : tv) x += 1.0f;
      for (int k = 0; k < nz; ++k) {
        std::memcpy(value + first + k * slice, &tv[k * kWidth], bytes);
        if (index) std::memcpy(index + first + k * slice, &ti[k * kWidth], bytes);
      }
    }
  });
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

struct Case {
  std::string key;          // for --only
  std::string description;  // what is timed
  int threads;
  std::function<void()> run;            // the timed work
  std::function<void()> after = [] {};  // untimed clean-up (freeing fresh buffers)
  std::vector<double> ms, cpu_ms;
};

double process_cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

}  // namespace

int main(int argc, char** argv) {
  int rounds = 7, max_threads = tbb::info::default_concurrency();
  std::string only;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--rounds") && a + 1 < argc)
      rounds = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--threads") && a + 1 < argc)
      max_threads = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--only") && a + 1 < argc)
      only = argv[++a];
    else {
      std::fprintf(stderr, "usage: %s [--rounds N] [--threads N] [--only CASE]\n", argv[0]);
      return 2;
    }
  }
  if (rounds < 1 || max_threads < 1) {
    std::fprintf(stderr, "%s: --rounds and --threads must be positive\n", argv[0]);
    return 2;
  }
  const std::string load_before = load_average();
  const cvt::Mask mask = ct_sized_mask();
  const std::size_t n = mask.size();
  const std::size_t bytes = n * sizeof(float);

  const std::vector<float> src(n, 1.0f);
  std::vector<float> warm(n, 0.0f);  // touched once, reused by every round
  std::vector<float> fresh;
  cvt::FeatureTransform ft_fresh;
  // Per thread count, so that no case's reuse depends on what another case left behind.
  std::vector<cvt::FeatureTransform> ft_reused(max_threads + 1), dist_reused(max_threads + 1);
  std::vector<Case> cases;
  cases.push_back({"memcpy-warm", "memcpy float volume, destination already touched", 1,
                   [&] { std::memcpy(warm.data(), src.data(), bytes); }});
  cases.push_back({"memcpy-fresh", "copy into a fresh allocation (vector copy, page faults)", 1,
                   [&] { fresh = src; }, [&] { fresh = std::vector<float>(); }});
  if (max_threads > 1)
    cases.push_back(
        {"memcpy-warm-mt", "memcpy split in 1 MiB chunks, destination touched", max_threads, [&] {
           const std::size_t chunk = std::size_t(1) << 18;  // floats
           tbb::parallel_for(std::size_t(0), (n + chunk - 1) / chunk, [&](std::size_t c) {
             const std::size_t b = c * chunk, e = std::min(n, b + chunk);
             std::memcpy(warm.data() + b, src.data() + b, (e - b) * sizeof(float));
           });
         }});
  cases.push_back({"zero-fresh", "std::vector<float>(n): fresh, zero-filled (no huge pages)", 1,
                   [&] { fresh = std::vector<float>(n); }, [&] { fresh = std::vector<float>(); }});
  // Buffers allocated like the EDT's outputs (huge pages where the kernel offers them).
  cvt::FeatureTransform traffic = cvt::compute_feature_transform(mask, true);
  float* const traffic_value = traffic.squared_distance_mm2.data.data();
  std::int32_t* const traffic_index = traffic.nearest.data.data();
  std::vector<int> thread_counts{1};
  if (max_threads > 1) thread_counts.push_back(max_threads);
  for (int t : thread_counts) {
    cases.push_back({"ft-reused", "EDT + feature transform, outputs reused", t,
                     [&, t] { cvt::compute_feature_transform(mask, ft_reused[t], true); }});
    cases.push_back({"ft-fresh", "EDT + feature transform, fresh outputs", t,
                     [&] { ft_fresh = cvt::compute_feature_transform(mask, true); },
                     [&] { ft_fresh = cvt::FeatureTransform(); }});
    cases.push_back({"dist-reused", "EDT distance only, output reused", t,
                     [&, t] { cvt::compute_feature_transform(mask, dist_reused[t], false); }});
    cases.push_back({"dist-fresh", "EDT distance only, fresh output", t,
                     [&] { ft_fresh = cvt::compute_feature_transform(mask, false); },
                     [&] { ft_fresh = cvt::FeatureTransform(); }});
    cases.push_back({"traffic-ft", "the FT's two sweeps of memory traffic, no arithmetic", t,
                     [&] { traffic_only(mask, traffic_value, traffic_index); }});
    cases.push_back({"traffic-dist", "the same for the distance only", t,
                     [&] { traffic_only(mask, traffic_value, nullptr); }});
  }
  if (!only.empty()) {
    std::vector<Case> kept;
    for (Case& c : cases)
      if (c.key == only && (kept.empty() || c.threads == max_threads)) kept = {c};
    if (kept.empty()) {
      std::fprintf(stderr, "%s: no case named '%s'\n", argv[0], only.c_str());
      return 2;
    }
    cases = kept;
  }
  // "Reused" means touched before: one untimed run of each first.
  for (int t : thread_counts) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, t);
    cvt::compute_feature_transform(mask, ft_reused[t], true);
    cvt::compute_feature_transform(mask, dist_reused[t], false);
  }

  for (int r = 0; r < rounds; ++r)
    for (Case& c : cases) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, c.threads);
      const double cpu0 = process_cpu_ms();
      const auto t0 = std::chrono::steady_clock::now();
      c.run();
      c.ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      c.cpu_ms.push_back(process_cpu_ms() - cpu0);
      c.after();
    }

  double warm_ms = 0;
  for (Case& c : cases)
    if (c.key == "memcpy-warm") warm_ms = *std::min_element(c.ms.begin(), c.ms.end());
  std::printf("%d x %d x %d = %.1f M voxels, %d rounds; load average before %s, after %s\n",
              mask.grid.dims[0], mask.grid.dims[1], mask.grid.dims[2], double(n) / 1e6, rounds,
              load_before.c_str(), load_average().c_str());
  std::printf("%-15s %-58s %7s %9s %9s %8s %10s %9s\n", "case", "what", "threads", "min ms",
              "median ms", "ns/voxel", "x memcpy", "CPU ms");
  for (Case& c : cases) {
    std::vector<double> sorted = c.ms;
    std::sort(sorted.begin(), sorted.end());
    const double best = sorted.front(), median = sorted[sorted.size() / 2];
    std::printf("%-15s %-58s %7d %9.1f %9.1f %8.2f", c.key.c_str(), c.description.c_str(),
                c.threads, best, median, best * 1e6 / double(n));
    std::printf(" %10.1f %9.1f\n", warm_ms > 0 ? best / warm_ms : 0.0,
                *std::min_element(c.cpu_ms.begin(), c.cpu_ms.end()));
  }
  std::printf(
      "ns/voxel: min wall time per voxel (not per thread); x memcpy: min / min of "
      "memcpy-warm; CPU ms: min process CPU time (all threads, kernel included)\n");
  return 0;
}
