#include "frame_stats.h"

#include <algorithm>
#include <cstdio>
#include <numeric>

namespace cvt::gui {

FrameStats frame_stats(std::vector<double> ms) {
  FrameStats s;
  s.frames = ms.size();
  if (ms.empty()) return s;
  std::sort(ms.begin(), ms.end());
  s.mean_ms = std::accumulate(ms.begin(), ms.end(), 0.0) / double(ms.size());
  s.median_ms = ms[ms.size() / 2];
  s.p95_ms = ms[std::min(ms.size() - 1, std::size_t(0.95 * double(ms.size())))];
  s.max_ms = ms.back();
  for (double t : ms) s.over_50ms += t > 50, s.over_100ms += t > 100;
  return s;
}

std::string describe(const std::string& label, const FrameStats& s) {
  char text[256];
  std::snprintf(text, sizeof text,
                "%s: %zu frames, mean %.1f ms, median %.1f ms, p95 %.1f ms, max %.1f ms, "
                ">50 ms: %zu, >100 ms: %zu",
                label.c_str(), s.frames, s.mean_ms, s.median_ms, s.p95_ms, s.max_ms, s.over_50ms,
                s.over_100ms);
  return text;
}

}  // namespace cvt::gui

namespace cvt::gui {

void BenchmarkRecorder::record(double ms, const std::string& job, bool ready) {
  if (!job.empty()) {
    busy_.push_back(ms);
    if (job == "CVT sampling" || job.rfind("Lloyd", 0) == 0) lloyd_.push_back(ms);
    return;
  }
  if (!ready || done()) return;
  (recorded_ < frames_ ? still_ : sweep_).push_back(ms);
  ++recorded_;
}

double BenchmarkRecorder::sweep_position() const {
  if (recorded_ < frames_ || done()) return -1;
  return 0.3 + 0.4 * double(recorded_ - frames_) / double(std::max(frames_ - 1, 1));
}

std::string BenchmarkRecorder::report() const {
  return describe("while jobs ran", frame_stats(busy_)) + "\n" +
         describe("  of which during Lloyd iterations", frame_stats(lloyd_)) + "\n" +
         describe("static view", frame_stats(still_)) + "\n" +
         describe("clip plane moving (cut-away rebuilt every frame)", frame_stats(sweep_)) + "\n";
}

}  // namespace cvt::gui
