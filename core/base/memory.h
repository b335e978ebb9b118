// Process memory figures, for reports and for refusing work that cannot fit.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace cvt {

// Peak resident set size of this process so far (bytes), from /proc/self/status (VmHWM).
std::size_t peak_rss_bytes();
// Current resident set size (bytes).
std::size_t current_rss_bytes();
// Memory the system can still give us (bytes), from /proc/meminfo (MemAvailable).
std::size_t available_memory_bytes();
// Throws InputError naming `what` when `bytes` exceeds `limit_bytes` (0 = available memory).
void require_memory(std::size_t bytes, std::size_t limit_bytes, const std::string& what);

// Faults in the pages of [data, data + bytes), by all threads, asking for huge pages first. A
// fresh buffer's first touch (the kernel zeroing and mapping its pages) otherwise runs on the
// one thread that fills it, and on the liver it took longer than the distance transform that
// then wrote the buffer. Only whole 2 MiB pages inside the buffer are touched, so a small buffer
// costs nothing. Linux only; elsewhere (or on kernels before 5.14) a no-op.
void fault_in_pages(void* data, std::size_t bytes);

// v sized to n elements (value-initialised), a fresh buffer's pages faulted in in parallel.
template <class T>
void resize_large(std::vector<T>& v, std::size_t n) {
  if (v.capacity() < n) {
    v = std::vector<T>();
    v.reserve(n);
    fault_in_pages(v.data(), n * sizeof(T));
  }
  v.resize(n);
}

}  // namespace cvt
