// Distance only: the lower envelope of 16 adjacent lines at once, without a stack.
//
// value[p] ← min_q value[q] + w·(p − q)². The argmin is monotone in p (the matrix
// v(p, q) = f_q + w·(p − q)² is Monge, since the kernel is convex): if q is a minimiser at p, no
// q' < q beats q at any p' > p, and no q' > q beats it at any p' < p. So once some minimiser is
// known at p − s and at p + s, the minimiser at p lies between them (divide and conquer, ~log2 n
// candidates per sample). On each line it also lies within √(f_p / w) of p, since q = p itself
// offers f_p: near features the search shrinks to a few samples. Sixteen lines share each search
// (the union of their ranges), one float per line in a vector, so the arithmetic is branch-free
// SIMD; searching more candidates than a line needs does not change its minimum.
//
// The search is in float: f_q + float(w·d²), all terms non-negative, so each candidate is within
// a rounding or two of its exact value (a minimiser missed by a rounding in the divide and
// conquer loses only by about a rounding too). The minimiser's value is then evaluated again in
// double as the stack code evaluates it, f_q + (w·d)·d rounded once, so the two paths differ
// only where float cannot order two nearly equal candidates (1 ulp, in ~1e-5 of the voxels).
//
// The search code (distance_min_plus_lines.inc) is compiled twice, under `#pragma GCC target`
// for AVX-512 and for AVX2, and picked at run time. GCC on x86-64 only: generic vectors,
// __builtin_shuffle and the CPU checks.
#include "distance_min_plus.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <utility>

#if defined(__x86_64__)
// GCC 12 warns, falsely, of its own _mm512_undefined_ps() in the masked intrinsics.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif

namespace cvt::detail {

MinPlusScratch::MinPlusScratch(const std::array<int, 3>& dims) {
  const int longest = std::max(dims[1], dims[2]);
  value.resize(std::size_t(kMinPlusLanes) * (longest + 3));
  argmin.resize(value.size());
  cut.resize(longest + 1);
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
namespace {

constexpr int kLanes = kMinPlusLanes;
constexpr float kInf = std::numeric_limits<float>::infinity();
// Rows read ahead (software prefetch) in the first, strided sweep over a group's lines: pass
// k's rows are a slice apart, too far for the hardware prefetchers.
constexpr int kPrefetchRows = 20;

// The best candidate so far, lane by lane: its value, its position, and its input value f.
template <class Lanes>
struct Best {
  Lanes value, arg, f;
};

}  // namespace

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"  // vector arguments of always-inline helpers only
#define CVT_ALWAYS_INLINE __attribute__((always_inline)) inline

// ---- AVX-512: sixteen floats in one 64-byte vector ----
#pragma GCC push_options
#pragma GCC target("avx512f")
namespace avx512 {

struct Lanes {
  typedef float D __attribute__((vector_size(64)));
  typedef std::int32_t I __attribute__((vector_size(64)));
  typedef float Du __attribute__((vector_size(64), aligned(4), may_alias));
  D v;
  static CVT_ALWAYS_INLINE Lanes splat(float x) { return {D{} + x}; }
  static CVT_ALWAYS_INLINE Lanes load(const float* at) { return {*(const Du*)at}; }
  CVT_ALWAYS_INLINE void store(float* at) const { *(Du*)at = v; }
  friend CVT_ALWAYS_INLINE Lanes max(Lanes x, Lanes y) { return {x.v > y.v ? x.v : y.v}; }
  friend CVT_ALWAYS_INLINE Lanes min(Lanes x, Lanes y) { return {x.v < y.v ? x.v : y.v}; }
  template <class Op>
  CVT_ALWAYS_INLINE float reduce(Op op) const {
    D m = op(v, __builtin_shuffle(v, I{8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7}));
    m = op(m, __builtin_shuffle(m, I{4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11}));
    m = op(m, __builtin_shuffle(m, I{2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13}));
    m = op(m, __builtin_shuffle(m, I{1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14}));
    return m[0];
  }
  CVT_ALWAYS_INLINE float lane_max() const {
    return reduce([](D x, D y) { return x > y ? x : y; });
  }
  CVT_ALWAYS_INLINE float lane_min() const {
    return reduce([](D x, D y) { return x < y ? x : y; });
  }
  CVT_ALWAYS_INLINE Lanes sqrt() const { return {_mm512_sqrt_ps(v)}; }
  CVT_ALWAYS_INLINE bool all_zero() const {
    const __m512i bits = _mm512_castps_si512(v);
    return _mm512_test_epi32_mask(bits, bits) == 0;
  }
  // first ← q where finite (q runs backwards), last ← max(last, q) where finite.
  CVT_ALWAYS_INLINE void note_finite(float q, Lanes& first, Lanes& last) const {
    first.v = v < kInf ? D{} + q : first.v;
    const D finite_q = v < kInf ? D{} + q : D{} - 1.0f;
    last.v = finite_q > last.v ? finite_q : last.v;
  }
  // Candidate q with input value f (this) at f + t: where strictly lower, it becomes the best
  // (value, argmin, and its f). The best value's own dependency chain is a single min (the
  // compare feeds only the others).
  CVT_ALWAYS_INLINE void offer(float t, Lanes q, Best<Lanes>& best) const {
    const __m512 value = _mm512_add_ps(v, _mm512_set1_ps(t));
    const __mmask16 lower = _mm512_cmp_ps_mask(value, best.value.v, _CMP_LT_OQ);
    best.arg.v = _mm512_mask_mov_ps(best.arg.v, lower, q.v);
    best.f.v = _mm512_mask_mov_ps(best.f.v, lower, v);
    best.value.v = _mm512_min_ps(value, best.value.v);
  }
  // Merges a second best in: where strictly lower, it wins.
  static CVT_ALWAYS_INLINE void merge(const Best<Lanes>& other, Best<Lanes>& best) {
    const __mmask16 lower = _mm512_cmp_ps_mask(other.value.v, best.value.v, _CMP_LT_OQ);
    best.arg.v = _mm512_mask_mov_ps(best.arg.v, lower, other.arg.v);
    best.f.v = _mm512_mask_mov_ps(best.f.v, lower, other.f.v);
    best.value.v = _mm512_mask_mov_ps(best.value.v, lower, other.value.v);
  }
  // The minimum as the stack code evaluates it: f + (w·d)·d in double, d = p − argmin, rounded
  // to float once. (This file is compiled without FMA contraction, which would round once less.)
  static CVT_ALWAYS_INLINE Lanes exact(const Best<Lanes>& best, float p, double w) {
    const __m512 d = _mm512_sub_ps(_mm512_set1_ps(p), best.arg.v);  // small integers: exact
    const __m512d wv = _mm512_set1_pd(w);
    auto half = [&](__m256 f, __m256 dh) {
      const __m512d dd = _mm512_cvtps_pd(dh);
      return _mm512_cvtpd_ps(_mm512_add_pd(_mm512_cvtps_pd(f), _mm512_mul_pd(_mm512_mul_pd(wv, dd), dd)));
    };
    const __m256 low = half(_mm512_castps512_ps256(best.f.v), _mm512_castps512_ps256(d));
    const __m256 high = half(_mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(best.f.v), 1)),
                             _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(d), 1)));
    return {_mm512_castpd_ps(_mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(low)),
                                                _mm256_castps_pd(high), 1))};
  }
  CVT_ALWAYS_INLINE Lanes operator+(float x) const { return {v + x}; }
  CVT_ALWAYS_INLINE Lanes operator*(float x) const { return {v * x}; }
  CVT_ALWAYS_INLINE Lanes operator+(Lanes x) const { return {v + x.v}; }
  CVT_ALWAYS_INLINE Lanes operator-(Lanes x) const { return {v - x.v}; }
};

#include "distance_min_plus_lines.inc"

}  // namespace avx512
#pragma GCC pop_options

// ---- AVX2: sixteen floats as two 32-byte halves ----
#pragma GCC push_options
#pragma GCC target("avx2")
namespace avx2 {

struct Lanes {
  typedef float D __attribute__((vector_size(32)));
  typedef std::int32_t I __attribute__((vector_size(32)));
  typedef float Du __attribute__((vector_size(32), aligned(4), may_alias));
  D a, b;
  static CVT_ALWAYS_INLINE Lanes splat(float x) { return {D{} + x, D{} + x}; }
  static CVT_ALWAYS_INLINE Lanes load(const float* at) {
    return {*(const Du*)at, *(const Du*)(at + 8)};
  }
  CVT_ALWAYS_INLINE void store(float* at) const {
    *(Du*)at = a;
    *(Du*)(at + 8) = b;
  }
  friend CVT_ALWAYS_INLINE Lanes max(Lanes x, Lanes y) {
    return {x.a > y.a ? x.a : y.a, x.b > y.b ? x.b : y.b};
  }
  friend CVT_ALWAYS_INLINE Lanes min(Lanes x, Lanes y) {
    return {x.a < y.a ? x.a : y.a, x.b < y.b ? x.b : y.b};
  }
  template <class Op>
  CVT_ALWAYS_INLINE float reduce(Op op) const {
    D m = op(a, b);
    m = op(m, __builtin_shuffle(m, I{4, 5, 6, 7, 0, 1, 2, 3}));
    m = op(m, __builtin_shuffle(m, I{2, 3, 0, 1, 6, 7, 4, 5}));
    m = op(m, __builtin_shuffle(m, I{1, 0, 3, 2, 5, 4, 7, 6}));
    return m[0];
  }
  CVT_ALWAYS_INLINE float lane_max() const {
    return reduce([](D x, D y) { return x > y ? x : y; });
  }
  CVT_ALWAYS_INLINE float lane_min() const {
    return reduce([](D x, D y) { return x < y ? x : y; });
  }
  CVT_ALWAYS_INLINE Lanes sqrt() const { return {_mm256_sqrt_ps(a), _mm256_sqrt_ps(b)}; }
  CVT_ALWAYS_INLINE bool all_zero() const {
    const __m256i bits = _mm256_or_si256(_mm256_castps_si256(a), _mm256_castps_si256(b));
    return _mm256_testz_si256(bits, bits);
  }
  CVT_ALWAYS_INLINE void note_finite(float q, Lanes& first, Lanes& last) const {
    first.a = a < kInf ? D{} + q : first.a;
    first.b = b < kInf ? D{} + q : first.b;
    const D qa = a < kInf ? D{} + q : D{} - 1.0f, qb = b < kInf ? D{} + q : D{} - 1.0f;
    last.a = qa > last.a ? qa : last.a;
    last.b = qb > last.b ? qb : last.b;
  }
  CVT_ALWAYS_INLINE void offer(float t, Lanes q, Best<Lanes>& best) const {
    const __m256 va = _mm256_add_ps(a, _mm256_set1_ps(t)), vb = _mm256_add_ps(b, _mm256_set1_ps(t));
    const __m256 lower_a = _mm256_cmp_ps(va, best.value.a, _CMP_LT_OQ);
    const __m256 lower_b = _mm256_cmp_ps(vb, best.value.b, _CMP_LT_OQ);
    best.arg.a = _mm256_blendv_ps(best.arg.a, q.a, lower_a);
    best.arg.b = _mm256_blendv_ps(best.arg.b, q.b, lower_b);
    best.f.a = _mm256_blendv_ps(best.f.a, a, lower_a);
    best.f.b = _mm256_blendv_ps(best.f.b, b, lower_b);
    best.value.a = _mm256_min_ps(va, best.value.a);
    best.value.b = _mm256_min_ps(vb, best.value.b);
  }
  static CVT_ALWAYS_INLINE void merge(const Best<Lanes>& other, Best<Lanes>& best) {
    const __m256 lower_a = _mm256_cmp_ps(other.value.a, best.value.a, _CMP_LT_OQ);
    const __m256 lower_b = _mm256_cmp_ps(other.value.b, best.value.b, _CMP_LT_OQ);
    for (auto [x, y] : {std::pair{&best.arg, &other.arg}, std::pair{&best.f, &other.f},
                        std::pair{&best.value, &other.value}}) {
      x->a = _mm256_blendv_ps(x->a, y->a, lower_a);
      x->b = _mm256_blendv_ps(x->b, y->b, lower_b);
    }
  }
  static CVT_ALWAYS_INLINE Lanes exact(const Best<Lanes>& best, float p, double w) {
    const __m256d wv = _mm256_set1_pd(w);
    auto quarter = [&](__m128 f, __m128 q) {
      const __m256d d = _mm256_cvtps_pd(_mm_sub_ps(_mm_set1_ps(p), q));  // small integers: exact
      return _mm256_cvtpd_ps(_mm256_add_pd(_mm256_cvtps_pd(f), _mm256_mul_pd(_mm256_mul_pd(wv, d), d)));
    };
    auto half = [&](__m256 f, __m256 q) {
      return _mm256_set_m128(quarter(_mm256_extractf128_ps(f, 1), _mm256_extractf128_ps(q, 1)),
                             quarter(_mm256_castps256_ps128(f), _mm256_castps256_ps128(q)));
    };
    return {half(best.f.a, best.arg.a), half(best.f.b, best.arg.b)};
  }
  CVT_ALWAYS_INLINE Lanes operator+(float x) const { return {a + x, b + x}; }
  CVT_ALWAYS_INLINE Lanes operator*(float x) const { return {a * x, b * x}; }
  CVT_ALWAYS_INLINE Lanes operator+(Lanes x) const { return {a + x.a, b + x.b}; }
  CVT_ALWAYS_INLINE Lanes operator-(Lanes x) const { return {a - x.a, b - x.b}; }
};

#include "distance_min_plus_lines.inc"

}  // namespace avx2
#pragma GCC pop_options

#undef CVT_ALWAYS_INLINE
#pragma GCC diagnostic pop

// 2: AVX-512, 1: AVX2, 0: neither. CVTMESH_SIMD=avx2 or =none caps it, so that tests and
// benchmarks can run the other paths on a machine that has AVX-512.
int instruction_set() {
  int isa = __builtin_cpu_supports("avx512f") ? 2 : __builtin_cpu_supports("avx2") ? 1 : 0;
  if (const char* cap = std::getenv("CVTMESH_SIMD")) {
    if (std::strcmp(cap, "avx2") == 0) isa = std::min(isa, 1);
    if (std::strcmp(cap, "none") == 0) isa = 0;
  }
  return isa;
}

bool min_plus(float* value, std::size_t first, std::size_t stride, int width, int n, double w,
              const float* w_d2, MinPlusScratch& s) {
  static const int isa = instruction_set();
  if (isa == 2)
    avx512::min_plus_group_lines(value, first, stride, width, n, w, w_d2, s);
  else if (isa == 1)
    avx2::min_plus_group_lines(value, first, stride, width, n, w, w_d2, s);
  return isa != 0;
}
#else
bool min_plus(float*, std::size_t, std::size_t, int, int, double, const float*, MinPlusScratch&) {
  return false;
}
#endif

}  // namespace cvt::detail
