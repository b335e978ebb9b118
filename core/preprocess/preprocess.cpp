#include "preprocess/preprocess.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>

#include <tbb/parallel_for.h>

#include "fields/distance_transform.h"
#include "base/errors.h"
#include "base/memory.h"
#include "fields/smoothing.h"
#include "preprocess/object_scale.h"

namespace cvt {

double effective_smoothing_sigma_mm(double sigma_mm, const Grid& grid) {
  if (sigma_mm > 0) return sigma_mm;
  return 0.5 * std::max({grid.spacing.x, grid.spacing.y, grid.spacing.z});
}

std::vector<std::int32_t> boundary_voxels(const Mask& object) {
  const Grid& g = object.grid;
  // Each k-slice's voxels in scan order, concatenated: the same list as one serial scan.
  std::vector<std::vector<std::int32_t>> slices(std::size_t(g.dims[2]));
  tbb::parallel_for(0, g.dims[2], [&](int k) {
    std::vector<std::int32_t>& out = slices[std::size_t(k)];
    for (int j = 0; j < g.dims[1]; ++j)
      for (int i = 0; i < g.dims[0]; ++i) {
        if (!object.at(i, j, k)) continue;
        const bool border = i == 0 || j == 0 || k == 0 || i == g.dims[0] - 1 ||
                            j == g.dims[1] - 1 || k == g.dims[2] - 1;
        if (border || !object.at(i - 1, j, k) || !object.at(i + 1, j, k) ||
            !object.at(i, j - 1, k) || !object.at(i, j + 1, k) || !object.at(i, j, k - 1) ||
            !object.at(i, j, k + 1))
          out.push_back(std::int32_t(g.linear(i, j, k)));
      }
  });
  std::vector<std::int32_t> out;
  for (const auto& slice : slices) out.insert(out.end(), slice.begin(), slice.end());
  return out;
}

namespace {

// Nearest voxel of the other phase, for both phases, in one volume: the inner transform
// (features = background) for object voxels, the outer one for background. Both transforms run
// in `work`, whose distance buffer is then free for the lfs transform: stage 1 first-touches
// one distance volume instead of three.
Volume<std::int32_t> nearest_of_other_phase(const Mask& object, FeatureTransform& work,
                                            const Progress& progress) {
  Volume<std::int32_t> nearest;
  {
    Mask background(object.grid, 0);
    for (std::size_t v = 0; v < object.size(); ++v) background.data[v] = !object.data[v];
    compute_feature_transform(background, work, true, progress);
    nearest = std::move(work.nearest);
  }
  compute_feature_transform(object, work, true, progress);
  tbb::parallel_for(std::size_t(0), object.size(), [&](std::size_t v) {
    if (!object.data[v]) nearest.data[v] = work.nearest.data[v];
  });
  work.nearest = {};  // stage 1's peak: the outer feature volume goes before the medial axis
  return nearest;
}

class StepTimer {
 public:
  StepTimer(std::vector<StepTime>& steps, const Progress& progress, const char* name)
      : steps_(steps), name_(name), start_(std::chrono::steady_clock::now()) {
    progress(name, 0.0);
  }
  ~StepTimer() {
    const std::chrono::duration<double> d = std::chrono::steady_clock::now() - start_;
    steps_.push_back({name_, d.count()});
  }

 private:
  std::vector<StepTime>& steps_;
  std::string name_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

namespace {

constexpr std::uint16_t kNoOpposite = 0xffff;

// Offsets −reach..reach per axis in 5 bits each.
std::uint16_t pack_offset(const std::array<int, 3>& a, const std::array<int, 3>& b) {
  static_assert(2 * kNearestOppositeReach < 31, "five bits per axis");
  std::uint16_t packed = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int d = b[axis] - a[axis];
    if (std::abs(d) > kNearestOppositeReach) return kNoOpposite;
    packed |= std::uint16_t((d + kNearestOppositeReach) << (5 * axis));
  }
  return packed;
}

Volume<std::uint16_t> packed_offsets(const Volume<std::int32_t>& nearest) {
  const Grid& g = nearest.grid;
  Volume<std::uint16_t> out(g, kNoOpposite);
  tbb::parallel_for(std::size_t(0), nearest.size(), [&](std::size_t v) {
    const std::int32_t u = nearest.data[v];
    if (u >= 0) out.data[v] = pack_offset(g.ijk(v), g.ijk(std::size_t(u)));
  });
  return out;
}

double squared_mm(const Grid& g, const std::array<int, 3>& d) {
  return d[0] * d[0] * g.spacing.x * g.spacing.x + d[1] * d[1] * g.spacing.y * g.spacing.y +
         d[2] * d[2] * g.spacing.z * g.spacing.z;
}

}  // namespace

std::int64_t nearest_opposite(const PreprocessResult& pre, std::size_t v, double within_mm) {
  const Mask& m = pre.object;
  const Grid& g = m.grid;
  const std::array<int, 3> c = g.ijk(v);
  const std::uint16_t packed = pre.nearest_opposite.data[v];
  if (packed != kNoOpposite) {
    std::array<int, 3> d;
    for (int axis = 0; axis < 3; ++axis)
      d[axis] = int((packed >> (5 * axis)) & 31) - kNearestOppositeReach;
    if (squared_mm(g, d) > within_mm * within_mm) return -1;
    return std::int64_t(g.linear(c[0] + d[0], c[1] + d[1], c[2] + d[2]));
  }
  // Beyond the kept offsets: all of them are farther than reach × the finest spacing.
  const double finest = std::min({g.spacing.x, g.spacing.y, g.spacing.z});
  if (within_mm <= kNearestOppositeReach * finest) return -1;
  int reach[3];
  for (int a = 0; a < 3; ++a) reach[a] = int(std::floor(within_mm / g.spacing[a]));
  double best = within_mm * within_mm;
  std::int64_t nearest = -1;
  for (int dk = -reach[2]; dk <= reach[2]; ++dk)
    for (int dj = -reach[1]; dj <= reach[1]; ++dj)
      for (int di = -reach[0]; di <= reach[0]; ++di) {
        const int i = c[0] + di, j = c[1] + dj, k = c[2] + dk;
        if (!g.contains(i, j, k) || m.at(i, j, k) == m.data[v]) continue;
        const double d2 = squared_mm(g, {di, dj, dk});
        if (d2 < best || (d2 == best && nearest < 0)) best = d2, nearest = g.linear(i, j, k);
      }
  return nearest;
}

PreprocessResult preprocess(const Image& image, const PreprocessOptions& options,
                            const Progress& progress) {
  // Not owned: the caller keeps the image.
  return preprocess(std::shared_ptr<const Image>(std::shared_ptr<const Image>(), &image), options,
                    progress);
}

PreprocessResult preprocess(std::shared_ptr<const Image> image, const PreprocessOptions& options,
                            const Progress& progress) {
  PreprocessResult r;
  {
    StepTimer t(r.steps, progress, "select object");
    r.object = select_object(*image, options.selection);
    // Stage 1 keeps ~12 bytes per crop voxel (mask, indicator, packed feature transform,
    // medial axis, lfs) and needs up to ~11 more while the transforms run.
    require_memory(r.object.size() * 23, options.max_bytes,
                   image->source + ": the object's crop (" + std::to_string(r.object.size()) +
                       " voxels)");
  }
  const std::string source = image->source;
  image.reset();
  {
    StepTimer t(r.steps, progress, "clean up");
    r.cleanup = clean_object(r.object, options.cleanup);
    if (std::find(r.object.data.begin(), r.object.data.end(), 1) == r.object.data.end())
      throw InputError(source + ": nothing is left of " + describe(options.selection) +
                       " after clean-up");
  }
  const Grid& g = r.object.grid;
  FeatureTransform work;
  Volume<std::int32_t> nearest;
  {
    StepTimer t(r.steps, progress, "distance transform");
    nearest = nearest_of_other_phase(r.object, work, progress);
  }
  {
    StepTimer t(r.steps, progress, "medial axis");
    r.volume_to_area_mm = volume_to_area_mm(r.object);
    r.sizing_unit_mm = sizing_unit_mm(r.object, r.volume_to_area_mm);
    MedialAxisOptions medial = options.medial_axis;
    medial.min_separation_mm = r.medial_min_separation_mm =
        effective_min_separation_mm(options.medial_axis, r.sizing_unit_mm);
    r.medial_axis = compute_medial_axis(r.object, nearest, medial, progress);
    r.nearest_opposite = packed_offsets(nearest);
    nearest = {};
  }
  {
    StepTimer t(r.steps, progress, "local feature size");
    r.lfs_bounds = effective_lfs_bounds(options.lfs, g, r.sizing_unit_mm);
    r.lfs_mm =
        compute_local_feature_size(r.medial_axis, r.lfs_bounds, progress, std::move(work));
  }
  // After the transforms, whose temporaries then need not share memory with it.
  {
    StepTimer t(r.steps, progress, "smoothed indicator");
    r.smoothing_sigma_mm = effective_smoothing_sigma_mm(options.smoothing_sigma_mm, g);
    r.indicator = smooth_indicator(r.object, r.smoothing_sigma_mm, progress);
  }
  {
    StepTimer t(r.steps, progress, "boundary voxels");
    r.boundary = boundary_voxels(r.object);
  }
  return r;
}

}  // namespace cvt
