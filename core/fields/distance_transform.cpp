// Separable exact EDT with feature transform. Pass i finds the nearest feature in each row, run
// by run; passes j and k take, for every line, the lower envelope of the parabolas
// f(q) + ((p − q)·spacing)² (Felzenszwalb & Huttenlocher 2012 — the same partial Voronoi
// diagrams as Maurer et al. 2003), carrying along the feature index of each parabola. Without
// the feature transform the same code runs with the index bookkeeping compiled out, so the
// distances are bitwise the same either way.
//
// Passes i and j are fused per k-slice, so pass j finds the slice still in cache. The strided j
// and k lines are processed in tiles of kTileWidth adjacent lines, copied in and out by
// contiguous row pieces rather than one strided element at a time. Lines are independent, so
// the result does not depend on how TBB splits them among threads.
#include "fields/distance_transform.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "base/errors.h"
#include "base/memory.h"
#include "base/multiversion.h"
#include "fields/byte_runs.h"


namespace cvt {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Lines per tile: 32 floats are two cache lines per row copied, enough to amortise the page
// (TLB) miss of each strided k row, while a 32 × 1000 tile of values + indices stays in L2.
constexpr int kTileWidth = 32;

// The envelope code has an AVX2 version (base/multiversion.h): its three-operand forms need
// fewer register copies.

// Per-thread work memory, sized once for the longest axis so no line allocates.
struct Scratch {
  std::vector<float> tile_value;         // a tile of lines, row-major (kTileWidth per row)
  std::vector<std::int32_t> tile_index;  // the matching feature indices
  // The lower envelope of one line, parabola by parabola: apex sample q, apex value f (mm²),
  // F = f + w·q², feature index, and where the parabola takes over from the one below it on the
  // stack, as a fraction: at (F_k − F_{k−1}) / (2w·(q_k − q_{k−1})).
  std::vector<double> site, site_f, site_F, rise, run;
  std::vector<std::int32_t> site_index;
  std::vector<int> ends_at;  // fill: how many intervals end just before each sample

  explicit Scratch(const std::array<int, 3>& dims) {
    const int longest = std::max({dims[0], dims[1], dims[2]});
    tile_value.resize(std::size_t(kTileWidth) * std::max(dims[1], dims[2]));
    tile_index.resize(tile_value.size());
    // A line's stack holds the sentinel plus at most one parabola per sample.
    for (auto* v : {&site, &site_f, &site_F, &rise, &run}) v->resize(longest + 1);
    site_index.resize(longest + 1);
    ends_at.resize(longest + 1);
  }
};

// Samples [from, to) of a row all take the feature at `feature`: squared distance
// squared_step[|i − feature|]. Plain loops over contiguous memory, so they vectorise.
template <bool kNearest>
void fill_gap(float* value, std::int32_t* index, int from, int to, int feature,
              std::int32_t row_start, const float* squared_step) {
  if (feature < from)
    for (int i = from; i < to; ++i) value[i] = squared_step[i - feature];
  else
    for (int i = from; i < to; ++i) value[i] = squared_step[feature - i];
  if constexpr (kNearest) std::fill(index + from, index + to, row_start + feature);
}

// Pass i on one row: squared distance to, and linear index of, the nearest feature in the row.
// squared_step[d] = float(w·d²), w the squared spacing. Equidistant features: the lower i wins.
// The row is walked run by run (features, then the gap to the next feature), so the per-voxel
// work is a vectorised fill.
template <bool kNearest>
void scan_row(const unsigned char* mask, float* value, std::int32_t* index, int n,
              std::int32_t row_start, const float* squared_step) {
  int feature = detail::next_nonzero_byte(mask, 0, n);
  if (feature == n) {  // no feature in the row
    std::fill_n(value, n, kInf);
    if constexpr (kNearest) std::fill_n(index, n, -1);
    return;
  }
  fill_gap<kNearest>(value, index, 0, feature, feature, row_start, squared_step);
  for (;;) {
    const int run_end = detail::next_zero_byte(mask, feature, n);
    std::fill(value + feature, value + run_end, 0.0f);
    if constexpr (kNearest)
      for (int i = feature; i < run_end; ++i) index[i] = row_start + i;
    if (run_end == n) return;
    const int last = run_end - 1;
    feature = detail::next_nonzero_byte(mask, run_end, n);
    if (feature == n) {
      fill_gap<kNearest>(value, index, run_end, n, last, row_start, squared_step);
      return;
    }
    // i − last ≤ feature − i, ties to the lower feature.
    const int split = (last + feature) / 2 + 1;
    fill_gap<kNearest>(value, index, run_end, split, last, row_start, squared_step);
    fill_gap<kNearest>(value, index, split, feature, feature, row_start, squared_step);
  }
}

// Writes samples [lo, hi) of a line from the lower envelope of the m parabolas in `s`. Each is
// lowest on one interval, left to right; the interval of k ends where k+1 takes over. Most
// intervals hold one or two samples, so rather than a loop per parabola (a mispredicted exit
// each), count the interval ends at each sample and walk the samples once, branch-free.
template <bool kNearest>
CVT_CLONES void fill_from_envelope(float* value, std::int32_t* index, double w, int lo,
                                            int hi, int m, Scratch& s) {
  constexpr int stride = kTileWidth;
  const double* site = s.site.data();
  const double* sf = s.site_f.data();
  const double* rise = s.rise.data();
  const double* run = s.run.data();
  const std::int32_t* sindex = s.site_index.data();
  int* ends_at = s.ends_at.data();
  std::fill(ends_at + lo, ends_at + hi + 1, 0);
  for (int k = 0; k + 1 < m; ++k) {
    const double t = rise[k + 1] / (2.0 * w * run[k + 1]);
    // Samples at t itself tie, and keep k. Ends beyond hi are never reached.
    const int end = t < lo ? lo : t >= hi ? hi : int(t) + 1;
    ends_at[end] += 1;
  }
  int k = 0;
  double x = lo;
  for (int p = lo; p < hi; ++p, x += 1.0) {
    k += ends_at[p];
    const double d = x - site[k];
    value[p * stride] = float(sf[k]) + float(w * d * d);
    if constexpr (kNearest) index[p * stride] = sindex[k];
  }
}

// Whether a stored squared distance is exactly +0 (they are never −0 or NaN); an integer compare
// is one branch where a float compare is two (unordered, then equal).
bool is_zero(const float* v) {
  std::uint32_t bits;
  std::memcpy(&bits, v, sizeof bits);
  return bits == 0;
}

// One line of n samples of a tile (kTileWidth apart), squared spacing w:
//   value[p] ← min_q value[q] + w·(p − q)²,  index[p] ← index[argmin q].
// +inf samples hold no feature. Ties (as far as double arithmetic resolves them) keep the lower
// q. The envelope arithmetic is in double; the stored value is then the float sum
// f_q + float(w·(p − q)²). That rounding is part of the result: the medial axis, and with it
// the mesh, follows these exact bits.
//
// A zero sample is a feature voxel: it keeps its value and index, and no parabola beyond it can
// win on its other side (f_r + w·(p − r)² > w·(p − q)² when r < q < p). So zeros cut the line into
// independent segments; a run of zeros costs one compare per sample, and only the non-zero
// samples cost any envelope work.
template <bool kNearest>
CVT_INLINE_IN_CLONES void envelope_line(float* value, std::int32_t* index, int n, double w,
                                        const double* w_q2, Scratch& s) {
  constexpr int stride = kTileWidth;
  double* site = s.site.data();
  double* sf = s.site_f.data();
  double* sF = s.site_F.data();
  double* rise = s.rise.data();
  double* run = s.run.data();
  std::int32_t* sindex = s.site_index.data();
  int m = 0;        // parabolas on the envelope stack
  int pending = 0;  // first sample not yet written
  auto put = [&](int q, double x, float fq, double Fq) {
    site[m] = x;
    sf[m] = fq;
    sF[m] = Fq;
    if constexpr (kNearest) sindex[m] = index[q * stride];
    ++m;
  };
  // Pushes the parabola of sample q, first dropping the top ones it hides: top v is hidden once
  // q takes over from v no later than v takes over from the one below it u,
  // (F_q − F_v)/(q − v) ≤ (F_v − F_u)/(v − u) = rise_v/run_v, cross-multiplied (positive runs)
  // so that no division delays the test. Exact ties drop v. The bottom parabola has rise −1 and
  // run 0, so the test always keeps it and needs no stack-size check.
  auto push = [&](int q, float fq) {
    const double x = q, Fq = double(fq) + w_q2[q];
    while ((Fq - sF[m - 1]) * run[m - 1] <= rise[m - 1] * (x - site[m - 1])) --m;
    rise[m] = Fq - sF[m - 1];
    run[m] = x - site[m - 1];
    put(q, x, fq, Fq);
  };
  // Starts a new envelope with the parabola of sample q alone.
  auto seed = [&](int q, float fq) {
    m = 0;
    rise[0] = -1.0;
    run[0] = 0.0;
    put(q, q, fq, double(fq) + w_q2[q]);
  };
  // The line starts with a sentinel parabola at −1 that is +inf everywhere: the test never drops
  // it ((F_q − ∞)·0 is NaN, and NaN ≤ x is false), it takes over nowhere (its successor's rise is
  // −∞), and the loop below needs no empty-stack check.
  site[0] = -1.0;
  sf[0] = sF[0] = kInf;
  rise[0] = -1.0;
  run[0] = 0.0;
  if constexpr (kNearest) sindex[0] = -1;
  m = 1;
  const float* sample = value;
  for (int q = 0; q < n; ++q, sample += stride) {
    const float fq = *sample;
    if (fq == kInf) continue;
    if (fq != 0.0f) {
      push(q, fq);
      continue;
    }
    if (pending < q) {  // the zero closes the segment before it
      push(q, fq);
      fill_from_envelope<kNearest>(value, index, w, pending, q, m, s);
    }
    const float* const end = value + std::ptrdiff_t(n) * stride;  // the rest of the run
    const float* next = sample + stride;
    while (next != end && is_zero(next)) next += stride;
    sample = next - stride;
    q = int((sample - value) / stride);
    seed(q, 0.0f);  // the segment after the run starts with the last zero's parabola alone
    pending = q + 1;
  }
  // With only the sentinel left there is no feature on the line: it stays +inf / −1.
  if (pending < n && sF[m - 1] < kInf)
    fill_from_envelope<kNearest>(value, index, w, pending, n, m, s);
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
CVT_CLONES void envelope_tile(float* value, std::int32_t* index, std::size_t first,
                                       int width, int n, std::size_t stride, double w,
                                       const double* w_q2, Scratch& s) {
  float* tv = s.tile_value.data();
  std::int32_t* ti = s.tile_index.data();
  for (int q = 0; q < n; ++q) {
    const std::size_t at = first + q * stride;
    copy_row(value + at, width, tv + std::size_t(q) * kTileWidth);
    if constexpr (kNearest) copy_row(index + at, width, ti + std::size_t(q) * kTileWidth);
  }
  for (int c = 0; c < width; ++c) envelope_line<kNearest>(tv + c, ti + c, n, w, w_q2, s);
  for (int q = 0; q < n; ++q) {
    const std::size_t at = first + q * stride;
    copy_row(tv + std::size_t(q) * kTileWidth, width, value + at);
    if constexpr (kNearest) copy_row(ti + std::size_t(q) * kTileWidth, width, index + at);
  }
}

template <bool kNearest>
void transform(const Mask& features, float* value, std::int32_t* index, const Progress& progress) {
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
      progress.check_cancelled();  // a slice takes well under a millisecond
      const std::size_t slice_start = std::size_t(k) * slice;
      for (int j = 0; j < ny; ++j) {
        const std::size_t row = slice_start + std::size_t(j) * nx;
        scan_row<kNearest>(features.data.data() + row, value + row,
                           kNearest ? index + row : nullptr, nx, std::int32_t(row),
                           squared_step_x.data());
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
          progress.check_cancelled();
          const int j = t / tiles_per_row, i0 = (t % tiles_per_row) * kTileWidth;
          envelope_tile<kNearest>(value, index, std::size_t(j) * nx + i0,
                                  std::min(kTileWidth, nx - i0), nz, slice, wz, wz_q2.data(), s);
        }
      });
}

void check_input(const Mask& features) {
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
}

}  // namespace

void compute_feature_transform(const Mask& features, FeatureTransform& out, bool compute_nearest,
                               const Progress& progress) {
  check_input(features);
  const Grid& grid = features.grid;
  const std::size_t n = grid.voxel_count();
  out.squared_distance_mm2.grid = grid;
  out.nearest.grid = grid;
  resize_large(out.squared_distance_mm2.data, n);
  if (compute_nearest)
    resize_large(out.nearest.data, n);
  else
    out.nearest.data.clear();
  if (n == 0) return;
  if (compute_nearest)
    transform<true>(features, out.squared_distance_mm2.data.data(), out.nearest.data.data(),
                    progress);
  else
    transform<false>(features, out.squared_distance_mm2.data.data(), nullptr, progress);
}

FeatureTransform compute_feature_transform(const Mask& features, bool compute_nearest,
                                           const Progress& progress) {
  FeatureTransform out;
  compute_feature_transform(features, out, compute_nearest, progress);
  return out;
}

}  // namespace cvt
