// Process memory figures, for reports and for refusing work that cannot fit.
#pragma once

#include <cstddef>
#include <string>

namespace cvt {

// Peak resident set size of this process so far (bytes), from /proc/self/status (VmHWM).
std::size_t peak_rss_bytes();
// Current resident set size (bytes).
std::size_t current_rss_bytes();
// Memory the system can still give us (bytes), from /proc/meminfo (MemAvailable).
std::size_t available_memory_bytes();
// Throws InputError naming `what` when `bytes` exceeds `limit_bytes` (0 = available memory).
void require_memory(std::size_t bytes, std::size_t limit_bytes, const std::string& what);

}  // namespace cvt
