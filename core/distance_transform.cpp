// Separable exact EDT with feature transform. Pass i finds the nearest feature in each row, run
// by run; passes j and k take, for every line, the lower envelope of the parabolas
// f(q) + ((p − q)·spacing)² (Felzenszwalb & Huttenlocher 2012 — the same partial Voronoi
// diagrams as Maurer et al. 2003), carrying along the feature index of each parabola.
//
// Passes i and j are fused per k-slice, so pass j finds the slice still in cache. The strided j
// and k lines are processed in tiles of kTileWidth adjacent lines, copied in and out by
// contiguous row pieces rather than one strided element at a time. Lines are independent, so
// the result does not depend on how TBB splits them among threads. Without the feature
// transform, passes j and k search 8 lines at once instead (min_plus, below) where AVX2 or
// AVX-512 is available.
#include "distance_transform.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "errors.h"

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace cvt {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// Lines per tile: 32 floats are two cache lines per row copied, enough to amortise the page
// (TLB) miss of each strided k row, while a 32 × 1000 tile of values + indices stays in L2.
constexpr int kTileWidth = 32;

// The envelope code is compiled twice on x86-64 GCC: for the baseline (SSE2) and for AVX2, picked
// at load time. The VEX three-operand forms save ~10% of the instructions (register copies); no
// FMA is enabled, so both versions round identically and give bitwise the same results.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define CVT_ENVELOPE_CLONES __attribute__((target_clones("avx2", "default")))
#define CVT_INLINE_IN_CLONES __attribute__((always_inline)) inline
#else
#define CVT_ENVELOPE_CLONES
#define CVT_INLINE_IN_CLONES inline
#endif

constexpr int kLanes = 8;  // lines per search group of the distance-only path
static_assert(kTileWidth % kLanes == 0);

struct DncScratch {
  std::vector<double> value;       // kLanes per sample: the lines' input values, as doubles
  std::vector<double> argmin;      // kLanes per sample: a minimiser found for it
  std::vector<double> value_max;   // per sample: the largest input value on the kLanes lines
  std::vector<unsigned char> cut;  // per sample: all kLanes lines have a feature there
  explicit DncScratch(const std::array<int, 3>& dims) {
    const int longest = std::max(dims[1], dims[2]);
    value.resize(std::size_t(kLanes) * (longest + 1));
    argmin.resize(value.size());
    value_max.resize(longest + 1);
    cut.resize(longest + 1);
  }
};

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
  DncScratch dnc;            // the distance-only path's

  explicit Scratch(const std::array<int, 3>& dims) : dnc(dims) {
    const int longest = std::max({dims[0], dims[1], dims[2]});
    tile_value.resize(std::size_t(kTileWidth) * std::max(dims[1], dims[2]));
    tile_index.resize(tile_value.size());
    // A line's stack holds the sentinel plus at most one parabola per sample.
    for (auto* v : {&site, &site_f, &site_F, &rise, &run}) v->resize(longest + 1);
    site_index.resize(longest + 1);
    ends_at.resize(longest + 1);
  }
};

// First i in [i, n) with a non-zero (feature) mask byte, or n. Skips eight bytes at a time, then
// finds the byte within the word one by one (independent of byte order).
int next_feature(const unsigned char* mask, int i, int n) {
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, mask + i, 8);
    if (w) break;
  }
  while (i < n && !mask[i]) ++i;
  return i;
}

// First i in [i, n) with a zero mask byte, or n.
int next_non_feature(const unsigned char* mask, int i, int n) {
  constexpr std::uint64_t kOnes = 0x0101010101010101ull, kHighs = 0x8080808080808080ull;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, mask + i, 8);
    if ((w - kOnes) & ~w & kHighs) break;  // non-zero exactly when some byte is zero
  }
  while (i < n && mask[i]) ++i;
  return i;
}

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
  int feature = next_feature(mask, 0, n);
  if (feature == n) {  // no feature in the row
    std::fill_n(value, n, kInf);
    if constexpr (kNearest) std::fill_n(index, n, -1);
    return;
  }
  fill_gap<kNearest>(value, index, 0, feature, feature, row_start, squared_step);
  for (;;) {
    const int run_end = next_non_feature(mask, feature, n);
    std::fill(value + feature, value + run_end, 0.0f);
    if constexpr (kNearest)
      for (int i = feature; i < run_end; ++i) index[i] = row_start + i;
    if (run_end == n) return;
    const int last = run_end - 1;
    feature = next_feature(mask, run_end, n);
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
CVT_ENVELOPE_CLONES void fill_from_envelope(float* value, std::int32_t* index, double w, int lo,
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
    value[p * stride] = float(sf[k] + w * d * d);
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
// q. The envelope arithmetic is in double, so the only rounding that matters is the float of
// the stored values.
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

// ---- Distance only: the lower envelope of 8 adjacent lines at once, without a stack ----------
//
// value[p] ← min_q value[q] + w·(p − q)². The argmin is monotone in p (the matrix
// v(p, q) = f_q + w·(p − q)² is Monge, since the kernel is convex): if q is a minimiser at p, no
// q' < q beats q at any p' > p, and no q' > q beats it at any p' < p. So once some minimiser is
// known at p − s and at p + s, the minimiser at p lies between them (divide and conquer, ~log2 n
// candidates per sample). It also lies within √(f_p / w) of p, since q = p itself offers f_p:
// near features the search shrinks to a few samples. Eight lines share each search (their union
// of ranges), one double per line in a vector, so the arithmetic is branch-free SIMD; searching
// more candidates than a line needs does not change its minimum.
//
// The minimum is taken over the same doubles the stack code evaluates, f_q + (w·d)·d, and
// rounded to float once, so both give the same floats wherever double arithmetic resolves which
// parabola is lowest.
// (GCC on x86-64 only: generic vectors, __builtin_shuffle and run-time ISA dispatch.)
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
// Eight lines' doubles, as one 64-byte vector (the AVX-512 instantiation) or as two 32-byte
// halves (the AVX2 one). The operations are the same IEEE operations on the same lanes either
// way (no FMA), so both give the same bits.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"  // vector arguments of always-inline helpers only
#define CVT_ALWAYS_INLINE __attribute__((always_inline)) inline

struct OneVector {
  typedef double D __attribute__((vector_size(64)));
  typedef std::int64_t I __attribute__((vector_size(64)));
  typedef double Du __attribute__((vector_size(64), aligned(8), may_alias));
  typedef float Fu __attribute__((vector_size(32), aligned(4), may_alias));
  D v;
  static CVT_ALWAYS_INLINE OneVector splat(double x) { return {D{} + x}; }
  static CVT_ALWAYS_INLINE OneVector load(const double* at) { return {*(const Du*)at}; }
  static CVT_ALWAYS_INLINE OneVector load(const float* at) {
    return {__builtin_convertvector(*(const Fu*)at, D)};
  }
  CVT_ALWAYS_INLINE void store(double* at) const { *(Du*)at = v; }
  CVT_ALWAYS_INLINE void store(float* at) const { *(Fu*)at = __builtin_convertvector(v, Fu); }
  friend CVT_ALWAYS_INLINE OneVector max(OneVector x, OneVector y) {
    return {x.v > y.v ? x.v : y.v};
  }
  friend CVT_ALWAYS_INLINE OneVector min(OneVector x, OneVector y) {
    return {x.v < y.v ? x.v : y.v};
  }
  CVT_ALWAYS_INLINE double lane_max() const {
    D m = v > __builtin_shuffle(v, I{4, 5, 6, 7, 0, 1, 2, 3})
              ? v
              : __builtin_shuffle(v, I{4, 5, 6, 7, 0, 1, 2, 3});
    const D a = __builtin_shuffle(m, I{2, 3, 0, 1, 6, 7, 4, 5});
    m = m > a ? m : a;
    const D b = __builtin_shuffle(m, I{1, 0, 3, 2, 5, 4, 7, 6});
    m = m > b ? m : b;
    return m[0];
  }
  CVT_ALWAYS_INLINE double lane_min() const {
    const D s = __builtin_shuffle(v, I{4, 5, 6, 7, 0, 1, 2, 3});
    D m = v < s ? v : s;
    const D a = __builtin_shuffle(m, I{2, 3, 0, 1, 6, 7, 4, 5});
    m = m < a ? m : a;
    const D b = __builtin_shuffle(m, I{1, 0, 3, 2, 5, 4, 7, 6});
    m = m < b ? m : b;
    return m[0];
  }
  // first ← q where finite (q runs backwards), last ← max(last, q) where finite.
  CVT_ALWAYS_INLINE void note_finite(double q, OneVector& first, OneVector& last) const {
    first.v = v < kInf ? D{} + q : first.v;
    const D finite_q = v < kInf ? D{} + q : D{} - 1.0;
    last.v = finite_q > last.v ? finite_q : last.v;
  }
  // Candidate q, at value f + t: where strictly lower, it becomes the best.
  CVT_ALWAYS_INLINE void offer(double t, OneVector q, OneVector& best, OneVector& arg) const {
    const D value = v + t;
    arg.v = value < best.v ? q.v : arg.v;
    best.v = value < best.v ? value : best.v;
  }
  // Merges a second (best, arg) pair in: where strictly lower, it wins.
  static CVT_ALWAYS_INLINE void merge(OneVector best2, OneVector arg2, OneVector& best,
                                      OneVector& arg) {
    arg.v = best2.v < best.v ? arg2.v : arg.v;
    best.v = best2.v < best.v ? best2.v : best.v;
  }
  CVT_ALWAYS_INLINE OneVector operator+(double x) const { return {v + x}; }
};

struct TwoHalves {
  typedef double D __attribute__((vector_size(32)));
  typedef std::int64_t I __attribute__((vector_size(32)));
  typedef double Du __attribute__((vector_size(32), aligned(8), may_alias));
  typedef float Fu __attribute__((vector_size(16), aligned(4), may_alias));
  D a, b;
  static CVT_ALWAYS_INLINE TwoHalves splat(double x) { return {D{} + x, D{} + x}; }
  static CVT_ALWAYS_INLINE TwoHalves load(const double* at) {
    return {*(const Du*)at, *(const Du*)(at + 4)};
  }
  static CVT_ALWAYS_INLINE TwoHalves load(const float* at) {
    return {__builtin_convertvector(*(const Fu*)at, D),
            __builtin_convertvector(*(const Fu*)(at + 4), D)};
  }
  CVT_ALWAYS_INLINE void store(double* at) const {
    *(Du*)at = a;
    *(Du*)(at + 4) = b;
  }
  CVT_ALWAYS_INLINE void store(float* at) const {
    *(Fu*)at = __builtin_convertvector(a, Fu);
    *(Fu*)(at + 4) = __builtin_convertvector(b, Fu);
  }
  friend CVT_ALWAYS_INLINE TwoHalves max(TwoHalves x, TwoHalves y) {
    return {x.a > y.a ? x.a : y.a, x.b > y.b ? x.b : y.b};
  }
  friend CVT_ALWAYS_INLINE TwoHalves min(TwoHalves x, TwoHalves y) {
    return {x.a < y.a ? x.a : y.a, x.b < y.b ? x.b : y.b};
  }
  CVT_ALWAYS_INLINE double lane_max() const {
    D m = a > b ? a : b;
    const D s = __builtin_shuffle(m, I{2, 3, 0, 1});
    m = m > s ? m : s;
    const D t = __builtin_shuffle(m, I{1, 0, 3, 2});
    m = m > t ? m : t;
    return m[0];
  }
  CVT_ALWAYS_INLINE double lane_min() const {
    D m = a < b ? a : b;
    const D s = __builtin_shuffle(m, I{2, 3, 0, 1});
    m = m < s ? m : s;
    const D t = __builtin_shuffle(m, I{1, 0, 3, 2});
    m = m < t ? m : t;
    return m[0];
  }
  CVT_ALWAYS_INLINE void note_finite(double q, TwoHalves& first, TwoHalves& last) const {
    first.a = a < kInf ? D{} + q : first.a;
    first.b = b < kInf ? D{} + q : first.b;
    const D qa = a < kInf ? D{} + q : D{} - 1.0, qb = b < kInf ? D{} + q : D{} - 1.0;
    last.a = qa > last.a ? qa : last.a;
    last.b = qb > last.b ? qb : last.b;
  }
  CVT_ALWAYS_INLINE void offer(double t, TwoHalves q, TwoHalves& best, TwoHalves& arg) const {
    const D va = a + t, vb = b + t;
    arg.a = va < best.a ? q.a : arg.a;
    arg.b = vb < best.b ? q.b : arg.b;
    best.a = va < best.a ? va : best.a;
    best.b = vb < best.b ? vb : best.b;
  }
  static CVT_ALWAYS_INLINE void merge(TwoHalves best2, TwoHalves arg2, TwoHalves& best,
                                      TwoHalves& arg) {
    arg.a = best2.a < best.a ? arg2.a : arg.a;
    arg.b = best2.b < best.b ? arg2.b : arg.b;
    best.a = best2.a < best.a ? best2.a : best.a;
    best.b = best2.b < best.b ? best2.b : best.b;
  }
  CVT_ALWAYS_INLINE TwoHalves operator+(double x) const { return {a + x, b + x}; }
};

// The `lanes` ≤ kLanes adjacent lines starting at value[first], n samples `stride` apart, in
// place. w_d2[d] = (w·d)·d for d = −(n − 1) … n − 1. Positions are held as doubles (exact
// integers), so that all vector work is on doubles.
template <class L>
CVT_ALWAYS_INLINE void min_plus_lines(float* value, std::size_t first_sample, std::size_t stride,
                                      int lanes, int n, double inv_w, const double* w_d2,
                                      DncScratch& s) {
  double* fd = s.value.data();
  double* argmin = s.argmin.data();
  double* value_max = s.value_max.data();
  unsigned char* cut = s.cut.data();
  auto sample = [&](int q) { return value + first_sample + std::size_t(q) * stride; };
  // Per line, the first and last finite sample (lines without any: n and −1, so that they never
  // widen a search); per sample, the largest value and whether it is a feature on all lines.
  L first = L::splat(n), last = L::splat(-1);
  for (int q = n - 1; q >= 0; --q) {
    L f;
    if (lanes == kLanes) {
      f = L::load(sample(q));
    } else {  // missing lines are +inf: lines without features, which never widen a search
      float padded[kLanes];
      std::fill_n(padded, kLanes, kInf);
      std::copy_n(sample(q), lanes, padded);
      f = L::load(padded);
    }
    f.store(fd + std::size_t(q) * kLanes);
    f.note_finite(q, first, last);
    value_max[q] = f.lane_max();
    cut[q] = value_max[q] == 0.0;  // squared distances are never negative or NaN
  }
  if (first.lane_min() == n) return;  // no feature on any of the lines: they stay +inf
  // Features on all lines at once cut the lines into independent segments, as in envelope_line.
  // Features keep their 0 in place.
  for (int a = 0; a < n;) {
    if (cut[a]) {
      ++a;
      continue;
    }
    int b = a + 1;
    while (b < n && !cut[b]) ++b;
    // Samples [a, b): the cuts a − 1 and b are their own minimisers, so the minimisers of the
    // segment lie between them.
    const L lo_bound = a > 0 ? L::splat(a - 1) : first, hi_bound = b < n ? L::splat(b) : last;
    const int m = b - a;
    int top = 1;  // the largest power of two ≤ m: position P = p − a + 1 ∈ [1, m] by lowest bit
    while (top * 2 <= m) top *= 2;
    for (int step = top; step >= 1; step /= 2)
      for (int P = step; P <= m; P += 2 * step) {
        const int p = a + P - 1;
        // Between the minimisers found at p − step and p + step, and within √(f_p / w) of p:
        // further away w·d² > f_p ≥ the result (with a relative margin of 1e-9, far above
        // rounding).
        const L lo = P > step ? max(L::load(argmin + std::size_t(p - step) * kLanes), lo_bound)
                              : lo_bound;
        const L hi = P + step <= m
                         ? min(L::load(argmin + std::size_t(p + step) * kLanes), hi_bound)
                         : hi_bound;
        const double reach = std::sqrt(value_max[p] * inv_w) + 1.0;
        const int from = int(std::max(lo.lane_min(), std::ceil(p - reach)));
        const int to = int(std::min(hi.lane_max(), std::floor(p + reach)));
        // Two independent (best, arg) chains over even and odd offsets, merged at the end.
        L best = L::splat(kInf), arg = L::splat(p), best2 = best, arg2 = arg;
        L qv = L::splat(from);
        const double* t = w_d2 - p;
        const double* f = fd + std::size_t(from) * kLanes;
        int q = from;
        for (; q < to; q += 2, f += 2 * kLanes) {
          L::load(f).offer(t[q], qv, best, arg);
          L::load(f + kLanes).offer(t[q + 1], qv + 1.0, best2, arg2);
          qv = qv + 2.0;
        }
        if (q == to) L::load(f).offer(t[q], qv, best, arg);
        L::merge(best2, arg2, best, arg);
        arg.store(argmin + std::size_t(p) * kLanes);
        if (lanes == kLanes) {
          best.store(sample(p));
        } else {
          float result[kLanes];
          best.store(result);
          std::copy_n(result, lanes, sample(p));
        }
      }
    a = b;
  }
}

#undef CVT_ALWAYS_INLINE
#pragma GCC diagnostic pop

// Distance only: `width` adjacent lines from value[first], n samples `stride` apart, in place,
// in groups of kLanes lines. Returns false, doing nothing, where neither AVX-512 nor AVX2 is
// available: the caller then runs the stack code (the vector code compiled for baseline SSE2
// was measured ~13× slower than the stack code).
__attribute__((target("avx512f"))) void min_plus_avx512(float* value, std::size_t first,
                                                          std::size_t stride, int width, int n,
                                                          double inv_w, const double* w_d2,
                                                          DncScratch& s) {
  for (int g = 0; g < width; g += kLanes)
    min_plus_lines<OneVector>(value, first + g, stride, std::min(kLanes, width - g), n, inv_w,
                              w_d2, s);
}

__attribute__((target("avx2"))) void min_plus_avx2(float* value, std::size_t first,
                                                     std::size_t stride, int width, int n,
                                                     double inv_w, const double* w_d2,
                                                     DncScratch& s) {
  for (int g = 0; g < width; g += kLanes)
    min_plus_lines<TwoHalves>(value, first + g, stride, std::min(kLanes, width - g), n, inv_w,
                              w_d2, s);
}

bool min_plus(float* value, std::size_t first, std::size_t stride, int width, int n, double w,
              const double* w_d2, DncScratch& s) {
  static const int isa = __builtin_cpu_supports("avx512f") ? 2
                         : __builtin_cpu_supports("avx2") ? 1
                                                          : 0;
  const double inv_w = (1.0 + 1e-9) / w;
  if (isa == 2)
    min_plus_avx512(value, first, stride, width, n, inv_w, w_d2, s);
  else if (isa == 1)
    min_plus_avx2(value, first, stride, width, n, inv_w, w_d2, s);
  return isa != 0;
}
#else
bool min_plus(float*, std::size_t, std::size_t, int, int, double, const double*, DncScratch&) {
  return false;
}
#endif

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
CVT_ENVELOPE_CLONES void envelope_tile(float* value, std::int32_t* index, std::size_t first,
                                       int width, int n, std::size_t stride, double w,
                                       const double* w_q2, const double* w_d2, Scratch& s) {
  if constexpr (!kNearest)
    if (min_plus(value, first, stride, width, n, w, w_d2, s.dnc)) return;
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
  // (w·d)·d for d = −(n − 1) … n − 1, exactly the stack code's w·d·d for a signed distance of
  // d samples; the pointers passed on are to d = 0.
  std::vector<double> wy_d2(2 * std::size_t(ny)), wz_d2(2 * std::size_t(nz));
  for (int d = 1 - ny; d < ny; ++d) wy_d2[d + ny] = wy * double(d) * double(d);
  for (int d = 1 - nz; d < nz; ++d) wz_d2[d + nz] = wz * double(d) * double(d);
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
                                nx, wy, wy_q2.data(), wy_d2.data() + ny, s);
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
                                  std::min(kTileWidth, nx - i0), nz, slice, wz, wz_q2.data(), wz_d2.data() + nz,
                                  s);
        }
      });
}

// Asks the kernel to back the whole 2 MiB pages inside [data, data + bytes) by huge pages.
void advise_huge_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
  const std::uintptr_t begin = (std::uintptr_t(data) + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t end = (std::uintptr_t(data) + bytes) & ~(kHuge - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

// Sizes `v` to n elements. A fresh buffer is first asked to be backed by huge pages: faulting
// in 2 MiB pages instead of 4 KiB ones makes the first touch of a large volume several times
// cheaper (Linux transparent huge pages in "madvise" mode; elsewhere a no-op).
template <class T>
void size_buffer(std::vector<T>& v, std::size_t n) {
  if (v.capacity() < n) {
    v = std::vector<T>();
    v.reserve(n);
    advise_huge_pages(v.data(), n * sizeof(T));
  }
  v.resize(n);
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
  size_buffer(out.squared_distance_mm2.data, n);
  if (compute_nearest)
    size_buffer(out.nearest.data, n);
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
