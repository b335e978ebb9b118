// Distance only: the lower envelope of 16 adjacent lines at once, without a stack.
//
// value[p] ← min_q value[q] + w·(p − q)². The argmin is monotone in p (the matrix
// v(p, q) = f_q + w·(p − q)² is Monge, since the kernel is convex): if q is a minimiser at p, no
// q' < q beats q at any p' > p, and no q' > q beats it at any p' < p. So once some minimiser is
// known at p − s and at p + s, the minimiser at p lies between them (divide and conquer, ~log2 n
// candidates per sample). On each line it also lies within √(f_p / w) of p, since q = p itself
// offers f_p: a search bounded on one side only (at a segment's ends) shrinks to a few samples
// near features. Sixteen lines share each search
// (the union of their ranges), one float per line in a vector, so the arithmetic is branch-free
// SIMD; searching more candidates than a line needs does not change its minimum.
//
// Values are floats, f_q + float(w·d²) with one rounding of the float sum, which is how the
// stack code of distance_transform.cpp evaluates the minimiser it finds in double: at the same
// minimiser the two paths give bitwise the same value. They differ only where float rounding
// orders two nearly equal candidates differently from double arithmetic (in about 1 voxel in a
// million, by an ulp or two): a minimiser that float rounding misplaces can narrow a later
// search by a sample, which then loses about a rounding.
//
// Per level of the divide and conquer, all candidate ranges are computed first, then searched:
// the ranges depend on the levels above only, so their reductions overlap instead of waiting
// behind each search's mispredicted loop exit. The last level's minimisers bound nothing, so
// its searches keep only the minimum (two vector operations per candidate row instead of four).
//
// The search (distance_min_plus_lines.inc), written on lanes of generic vector parts
// (distance_min_plus_lanes.inc), is compiled twice, under `#pragma GCC target` for AVX-512 and
// for AVX2, and picked at run time. GCC on x86-64 only: generic vectors, __builtin_shuffle and
// the CPU checks.
#include "fields/distance_min_plus.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <utility>

#include "fields/byte_runs.h"

#if defined(__x86_64__)
// GCC 12 warns, falsely, of its own _mm512_undefined_ps() inside its AVX-512 intrinsics.
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
  span.resize(2 * std::size_t(longest + 1));
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
namespace {

constexpr int kLanes = kMinPlusLanes;
constexpr float kInf = std::numeric_limits<float>::infinity();
// Rows read ahead (software prefetch) in the first, strided sweep over a group's lines: pass
// k's rows are a slice apart, too far for the hardware prefetchers.
constexpr int kPrefetchRows = 20;

}  // namespace

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"  // vector arguments of always-inline helpers only
#define CVT_ALWAYS_INLINE __attribute__((always_inline)) inline

// ---- AVX-512: 64-byte vectors ----
#pragma GCC push_options
#pragma GCC target("avx512f")
namespace avx512 {

struct Part {
  typedef float D __attribute__((vector_size(64)));
  typedef std::int32_t I __attribute__((vector_size(64)));
  typedef float Du __attribute__((vector_size(64), aligned(4), may_alias));
  static CVT_ALWAYS_INLINE D sqrt(D x) { return _mm512_sqrt_ps(x); }
  static CVT_ALWAYS_INLINE bool any_bits(D x) {
    const __m512i bits = _mm512_castps_si512(x);
    return _mm512_test_epi32_mask(bits, bits) != 0;
  }
  // The minima of x and of y, reduced side by side in the two halves of one vector.
  static CVT_ALWAYS_INLINE std::pair<float, float> min_pair(D x, D y) {
    D m = __builtin_shuffle(x, y, I{0, 1, 2, 3, 4, 5, 6, 7, 16, 17, 18, 19, 20, 21, 22, 23});
    const D other = __builtin_shuffle(x, y, I{8, 9, 10, 11, 12, 13, 14, 15, 24, 25, 26, 27, 28, 29, 30, 31});
    m = m < other ? m : other;
    D s = __builtin_shuffle(m, I{4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11});
    m = m < s ? m : s;
    s = __builtin_shuffle(m, I{2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13});
    m = m < s ? m : s;
    s = __builtin_shuffle(m, I{1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14});
    m = m < s ? m : s;
    return {m[0], m[8]};
  }
};

#include "fields/distance_min_plus_lanes.inc"
#include "fields/distance_min_plus_lines.inc"

}  // namespace avx512
#pragma GCC pop_options

// ---- AVX2: 32-byte vectors ----
#pragma GCC push_options
#pragma GCC target("avx2")
namespace avx2 {

struct Part {
  typedef float D __attribute__((vector_size(32)));
  typedef std::int32_t I __attribute__((vector_size(32)));
  typedef float Du __attribute__((vector_size(32), aligned(4), may_alias));
  static CVT_ALWAYS_INLINE D sqrt(D x) { return _mm256_sqrt_ps(x); }
  static CVT_ALWAYS_INLINE bool any_bits(D x) {
    const __m256i bits = _mm256_castps_si256(x);
    return !_mm256_testz_si256(bits, bits);
  }
  static CVT_ALWAYS_INLINE std::pair<float, float> min_pair(D x, D y) {
    D m = __builtin_shuffle(x, y, I{0, 1, 2, 3, 8, 9, 10, 11});
    const D other = __builtin_shuffle(x, y, I{4, 5, 6, 7, 12, 13, 14, 15});
    m = m < other ? m : other;
    D s = __builtin_shuffle(m, I{2, 3, 0, 1, 6, 7, 4, 5});
    m = m < s ? m : s;
    s = __builtin_shuffle(m, I{1, 0, 3, 2, 5, 4, 7, 6});
    m = m < s ? m : s;
    return {m[0], m[4]};
  }
};

#include "fields/distance_min_plus_lanes.inc"
#include "fields/distance_min_plus_lines.inc"

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
  // Absurd spacings (1 / w out of float's range) would make the reach NaN: stack code, in double.
  if (isa == 0 || !std::isnormal(float(1.0 / w))) return false;
  if (isa == 2)
    avx512::min_plus_group_lines(value, first, stride, width, n, w, w_d2, s);
  else if (isa == 1)
    avx2::min_plus_group_lines(value, first, stride, width, n, w, w_d2, s);
  return true;
}
#else
bool min_plus(float*, std::size_t, std::size_t, int, int, double, const float*, MinPlusScratch&) {
  return false;
}
#endif

}  // namespace cvt::detail
