// The distance-only passes j and k of the distance transform, without a stack: sixteen adjacent
// lines searched at once with AVX-512 or AVX2 (distance_min_plus.cpp says how). Internal to
// distance_transform.cpp.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace cvt::detail {

constexpr int kMinPlusLanes = 16;  // lines per search group

// Per-thread work memory, sized once for the longest line.
struct MinPlusScratch {
  std::vector<float> value;        // kMinPlusLanes per sample: the lines' input values
  std::vector<float> argmin;       // kMinPlusLanes per sample: a minimiser found for it
  std::vector<unsigned char> cut;  // per sample: all lines of the group have a feature there
  std::vector<int> span;           // per search of one level: its first and last candidate
  explicit MinPlusScratch(const std::array<int, 3>& dims);
};

// value[p] ← min_q value[q] + w·(p − q)² on `width` adjacent lines from value[first], each n
// samples `stride` apart, in place, in groups of kMinPlusLanes lines. w_d2[d] = float(w·d²) for
// d = −(n − 1) … n + 2 (the search reads three guard rows past a line's end). Returns false,
// doing nothing, where neither AVX-512 nor AVX2 is available (or the compiler is not GCC on
// x86-64 Linux), or where 1 / w is no normal float: the caller then runs its stack code.
// The environment variable CVTMESH_SIMD=avx2 or =none, read once, caps the instruction set (for
// tests and benchmarks of the other paths).
bool min_plus(float* value, std::size_t first, std::size_t stride, int width, int n, double w,
              const float* w_d2, MinPlusScratch& s);

}  // namespace cvt::detail
