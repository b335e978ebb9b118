// Finding the next run boundary in a mask row eight bytes at a time: the distance transform's
// pass i walks each row run by run, and the voxelizer keeps its voxels as runs.
#pragma once

#include <cstdint>
#include <cstring>

namespace cvt::detail {

// First i in [i, n) with a non-zero byte, or n. Skips eight bytes at a time, then finds the
// byte within the word one by one (independent of byte order).
inline int next_nonzero_byte(const unsigned char* bytes, int i, int n) {
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, bytes + i, 8);
    if (w) break;
  }
  while (i < n && !bytes[i]) ++i;
  return i;
}

// First i in [i, n) with a zero byte, or n.
inline int next_zero_byte(const unsigned char* bytes, int i, int n) {
  constexpr std::uint64_t kOnes = 0x0101010101010101ull, kHighs = 0x8080808080808080ull;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, bytes + i, 8);
    if ((w - kOnes) & ~w & kHighs) break;  // non-zero exactly when some byte is zero
  }
  while (i < n && bytes[i]) ++i;
  return i;
}

}  // namespace cvt::detail
