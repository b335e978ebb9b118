// Separable exact EDT with feature transform. Pass i is a two-sided scan for the nearest feature
// in each row; passes j and k take, for every line, the lower envelope of the parabolas
// f(q) + ((p − q)·spacing)² (Felzenszwalb & Huttenlocher 2012 — the same partial Voronoi
// diagrams as Maurer et al. 2003), carrying along the feature index of each parabola.
//
// Passes i and j are fused per k-slice, so pass j finds the slice still in cache. The strided j
// and k lines are processed in tiles of kTileWidth adjacent lines, copied in and out by
// contiguous row pieces rather than one strided element at a time. Lines are independent, so
// the result does not depend on how TBB splits them among threads.
#include "distance_transform.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "errors.h"

namespace cvt {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Lines per tile: 32 floats are two cache lines per row copied, enough to amortise the page
// (TLB) miss of each strided k row, while a 32 × 1000 tile of values + indices stays in L2.
constexpr int kTileWidth = 32;

// Per-thread work memory, sized once for the longest axis so no line allocates.
struct Scratch {
  std::vector<int> left;                 // pass i: last feature at or before each i
  std::vector<float> tile_value;         // a tile of lines, row-major (kTileWidth per row)
  std::vector<std::int32_t> tile_index;  // the matching feature indices
  // The lower envelope of one line: apex sample q, apex value f (mm²), f + w·q² (the form the
  // intersection test uses) and feature index of each parabola.
  std::vector<double> site;
  std::vector<double> site_f, site_F;
  std::vector<std::int32_t> site_index;
  std::vector<int> ends_at;  // fill: how many intervals end just before each sample

  explicit Scratch(const std::array<int, 3>& dims) {
    const int longest = std::max({dims[0], dims[1], dims[2]});
    left.resize(dims[0]);
    tile_value.resize(std::size_t(kTileWidth) * std::max(dims[1], dims[2]));
    tile_index.resize(tile_value.size());
    site.resize(longest);
    site_f.resize(longest);
    site_F.resize(longest);
    site_index.resize(longest);
    ends_at.resize(longest + 1);
  }
};

// Pass i on one row: squared distance to, and linear index of, the nearest feature in the row.
// squared_step[d] = float(w·d²), w the squared spacing. Equidistant features: the lower i wins.
// A missing feature on one side sits kFar away, so both scans are simple selects.
template <bool kNearest>
void scan_row(const unsigned char* mask, float* value, std::int32_t* index, int n,
              std::int32_t row_start, const float* squared_step, int* left) {
  constexpr int kFar = 1 << 30;
  int last = -kFar;
  for (int i = 0; i < n; ++i) {
    last = mask[i] ? i : last;
    left[i] = last;
  }
  if (last < 0) {  // no feature in the row
    std::fill_n(value, n, kInf);
    if constexpr (kNearest) std::fill_n(index, n, -1);
    return;
  }
  int next = kFar;
  for (int i = n - 1; i >= 0; --i) {
    next = mask[i] ? i : next;
    const int pick = next - i < i - left[i] ? next : left[i];
    value[i] = squared_step[i - pick < 0 ? pick - i : i - pick];
    if constexpr (kNearest) index[i] = row_start + pick;
  }
}

// Writes samples [lo, hi) of a line from the lower envelope of the m parabolas in `s`. Each is
// lowest on one interval, left to right; the interval of k ends where it meets k+1, at
// t = (F_{k+1} − F_k) / (2w·(q_{k+1} − q_k)). Most intervals hold one or two samples, so rather
// than a loop per parabola (a mispredicted exit each), count the interval ends at each sample
// and walk the samples once, branch-free.
template <bool kNearest>
void fill_from_envelope(float* value, std::int32_t* index, std::ptrdiff_t stride, double w, int lo,
                        int hi, int m, Scratch& s) {
  const double* site = s.site.data();
  const double* sf = s.site_f.data();
  const double* sF = s.site_F.data();
  int* ends_at = s.ends_at.data();
  std::fill(ends_at + lo, ends_at + hi + 1, 0);
  for (int k = 0; k + 1 < m; ++k) {
    const double t = (sF[k + 1] - sF[k]) / (2.0 * w * (site[k + 1] - site[k]));
    // Samples at t itself tie, and keep k. Ends beyond hi are never reached.
    const int end = t < lo ? lo : t >= hi ? hi : int(t) + 1;
    ends_at[end] += 1;
  }
  int k = 0;
  for (int p = lo; p < hi; ++p) {
    k += ends_at[p];
    const double d = p - site[k];
    value[p * stride] = float(sf[k] + w * d * d);
    if constexpr (kNearest) index[p * stride] = s.site_index[k];
  }
}

// One j or k line of n samples at `stride` apart, squared spacing w:
//   value[p] ← min_q value[q] + w·(p − q)²,  index[p] ← index[argmin q].
// +inf samples hold no feature. Ties (as far as double arithmetic resolves them) keep the lower
// q. All arithmetic is in double on sample indices, so the only rounding that matters is the
// float of the stored values.
//
// A zero sample is a feature voxel: it keeps its value and index, and no parabola beyond it can
// win on its other side (f_r + w·(p − r)² > w·(p − q)² when r < q < p). So zeros cut the line into
// independent segments, and only the non-zero samples cost any work.
template <bool kNearest>
void envelope_line(float* value, std::int32_t* index, int n, std::ptrdiff_t stride, double w,
                   const double* w_q2, Scratch& s) {
  double* site = s.site.data();
  double* sf = s.site_f.data();
  double* sF = s.site_F.data();
  std::int32_t* sindex = s.site_index.data();
  int m = 0;        // parabolas on the envelope stack
  int pending = 0;  // first sample not yet written
  auto reset_to = [&](double x, double F, std::int32_t feature) {
    site[0] = x;  // the segment after a zero starts with the zero's parabola alone
    sf[0] = 0.0;
    sF[0] = F;
    if constexpr (kNearest) sindex[0] = feature;
    m = 1;
  };
  for (int q = 0; q < n; ++q) {
    const float fq = value[q * stride];
    if (fq == kInf) continue;
    const double x = q, Fq = double(fq) + w_q2[q];
    const std::int32_t feature = kNearest ? index[q * stride] : 0;
    if (fq == 0.0f && pending == q) {  // a run of zeros: nothing to write
      reset_to(x, Fq, feature);
      pending = q + 1;
      continue;
    }
    // The top parabola v is hidden once q's crosses it no later than v crosses the one below
    // it, u: (F_q − F_v)/(q − v) ≤ (F_v − F_u)/(v − u), cross-multiplied (positive
    // denominators, and w cancels) so the build needs no division. Exact ties drop v.
    while (m >= 2 && (Fq - sF[m - 1]) * (site[m - 1] - site[m - 2]) <=
                         (sF[m - 1] - sF[m - 2]) * (x - site[m - 1]))
      --m;
    site[m] = x;
    sf[m] = fq;
    sF[m] = Fq;
    if constexpr (kNearest) sindex[m] = feature;
    ++m;
    if (fq == 0.0f) {
      fill_from_envelope<kNearest>(value, index, stride, w, pending, q, m, s);
      reset_to(x, Fq, feature);
      pending = q + 1;
    }
  }
  // No feature on the line: it stays +inf / −1.
  if (m > 0 && pending < n) fill_from_envelope<kNearest>(value, index, stride, w, pending, n, m, s);
}

template <class T>
void copy_row(const T* from, int width, T* to) {
  // A full tile row has a compile-time size: inlined vector moves instead of a memmove call.
  if (width == kTileWidth)
    std::memcpy(to, from, kTileWidth * sizeof(T));
  else
    std::memcpy(to, from, std::size_t(width) * sizeof(T));
}

// Runs envelope_line over the `width` adjacent lines starting at `first`, each `n` samples at
// `stride` apart in the volume, through the tile buffer (contiguous row copies in and out).
template <bool kNearest>
void envelope_tile(float* value, std::int32_t* index, std::size_t first, int width, int n,
                   std::size_t stride, double w, const double* w_q2, Scratch& s) {
  float* tv = s.tile_value.data();
  std::int32_t* ti = s.tile_index.data();
  for (int q = 0; q < n; ++q) {
    const std::size_t at = first + q * stride;
    copy_row(value + at, width, tv + std::size_t(q) * kTileWidth);
    if constexpr (kNearest) copy_row(index + at, width, ti + std::size_t(q) * kTileWidth);
  }
  for (int c = 0; c < width; ++c)
    envelope_line<kNearest>(tv + c, ti + c, n, kTileWidth, w, w_q2, s);
  for (int q = 0; q < n; ++q) {
    const std::size_t at = first + q * stride;
    copy_row(tv + std::size_t(q) * kTileWidth, width, value + at);
    if constexpr (kNearest) copy_row(ti + std::size_t(q) * kTileWidth, width, index + at);
  }
}

template <bool kNearest>
void transform(const Mask& features, float* value, std::int32_t* index) {
  const auto [nx, ny, nz] = features.grid.dims;
  const Vec3& spacing = features.grid.spacing;
  const double wx = spacing.x * spacing.x, wy = spacing.y * spacing.y, wz = spacing.z * spacing.z;
  std::vector<float> squared_step_x(nx);
  for (int d = 0; d < nx; ++d) squared_step_x[d] = float(wx * double(d) * double(d));
  std::vector<double> wy_q2(ny), wz_q2(nz);  // w·q², the envelope test's form of the position
  for (int q = 0; q < ny; ++q) wy_q2[q] = wy * double(q) * double(q);
  for (int q = 0; q < nz; ++q) wz_q2[q] = wz * double(q) * double(q);
  const std::size_t slice = std::size_t(nx) * std::size_t(ny);
  const int tiles_per_row = (nx + kTileWidth - 1) / kTileWidth;
  tbb::enumerable_thread_specific<Scratch> scratch(features.grid.dims);

  // Passes i and j, one k-slice at a time.
  tbb::parallel_for(tbb::blocked_range<int>(0, nz), [&](const tbb::blocked_range<int>& r) {
    Scratch& s = scratch.local();
    for (int k = r.begin(); k < r.end(); ++k) {
      const std::size_t slice_start = std::size_t(k) * slice;
      for (int j = 0; j < ny; ++j) {
        const std::size_t row = slice_start + std::size_t(j) * nx;
        scan_row<kNearest>(features.data.data() + row, value + row,
                           kNearest ? index + row : nullptr, nx, std::int32_t(row),
                           squared_step_x.data(), s.left.data());
      }
      if (ny == 1) continue;
      for (int t = 0; t < tiles_per_row; ++t) {
        const int i0 = t * kTileWidth;
        envelope_tile<kNearest>(value, index, slice_start + i0, std::min(kTileWidth, nx - i0), ny,
                                nx, wy, wy_q2.data(), s);
      }
    }
  });
  if (nz == 1) return;

  // Pass k, over tiles of adjacent (i, j) lines; consecutive tiles read consecutive memory.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, ny * tiles_per_row), [&](const tbb::blocked_range<int>& r) {
        Scratch& s = scratch.local();
        for (int t = r.begin(); t < r.end(); ++t) {
          const int j = t / tiles_per_row, i0 = (t % tiles_per_row) * kTileWidth;
          envelope_tile<kNearest>(value, index, std::size_t(j) * nx + i0,
                                  std::min(kTileWidth, nx - i0), nz, slice, wz, wz_q2.data(), s);
        }
      });
}

}  // namespace

FeatureTransform compute_feature_transform(const Mask& features, bool compute_nearest) {
  const Grid& grid = features.grid;
  if (grid.dims[0] < 0 || grid.dims[1] < 0 || grid.dims[2] < 0)
    throw InputError("distance transform: negative grid dimensions");
  if (grid.voxel_count() > std::size_t(std::numeric_limits<std::int32_t>::max()))
    throw InputError("distance transform: " + std::to_string(grid.voxel_count()) +
                     " voxels exceed the int32 feature index range");
  for (double s : {grid.spacing.x, grid.spacing.y, grid.spacing.z})
    if (!(s > 0.0 && s < std::numeric_limits<double>::infinity()))
      throw InputError("distance transform: voxel spacing must be positive and finite");
  if (features.data.size() != grid.voxel_count())
    throw InputError("distance transform: feature mask size does not match its grid");

  FeatureTransform out;
  out.squared_distance_mm2 = Volume<float>(grid);
  out.nearest.grid = grid;
  if (grid.voxel_count() == 0) return out;
  if (compute_nearest) {
    out.nearest.data.resize(grid.voxel_count());
    transform<true>(features, out.squared_distance_mm2.data.data(), out.nearest.data.data());
  } else {
    transform<false>(features, out.squared_distance_mm2.data.data(), nullptr);
  }
  return out;
}

}  // namespace cvt
