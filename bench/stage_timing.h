// Shared helpers for the stage benchmarks: wall clock and peak memory in one table row.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

#include "base/memory.h"

namespace cvt::bench {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

inline void print_row(const std::string& step, double wall_s) {
  std::printf("%-28s %9.3f s   peak RSS %7.1f MB\n", step.c_str(), wall_s,
              double(peak_rss_bytes()) / (1024.0 * 1024.0));
}

}  // namespace cvt::bench
