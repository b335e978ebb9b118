// Frame-time statistics for --benchmark-frames (GL-free).
#pragma once

#include <string>
#include <vector>

namespace cvt::gui {

struct FrameStats {
  std::size_t frames = 0;
  double mean_ms = 0, median_ms = 0, p95_ms = 0, max_ms = 0;
  std::size_t over_50ms = 0, over_100ms = 0;
};

FrameStats frame_stats(std::vector<double> frame_ms);

// CPU time (ms) used so far by the calling thread and the rasteriser's threads (Mesa
// llvmpipe's, named "llvmpipe-N"), from /proc/self/task/*/schedstat: the difference over a
// frame is what the frame cost, apart from the time it waited for a CPU on a loaded machine.
// Negative when /proc cannot tell.
double render_cpu_ms();
// "label: N frames, mean … ms, median …, p95 …, max …, >50 ms: …, >100 ms: …"
std::string describe(const std::string& label, const FrameStats& stats);

// The frames of a benchmark run: every frame while jobs run (and apart, those during Lloyd
// iterations), then `frames` frames of the view as set, then `frames` with the clip plane
// sweeping (each one rebuilds the cut-away, as dragging the clip slider does). Each frame's
// wall time, and if given (≥ 0) its CPU time (render_cpu_ms), reported as "LABEL (CPU)".
class BenchmarkRecorder {
 public:
  explicit BenchmarkRecorder(int frames) : frames_(frames) {}
  // One frame: its time, the job that ran during it ("" if none), and whether the scene is
  // complete (every job done and shown).
  void record(double ms, const std::string& job, bool ready, double cpu_ms = -1);
  // During the sweep: the clip position for the next frame (else a negative value).
  double sweep_position() const;
  bool done() const { return recorded_ >= 2 * frames_; }
  std::string report() const;

 private:
  int frames_ = 0, recorded_ = 0;
  std::vector<double> busy_, lloyd_, still_, sweep_;
  std::vector<double> busy_cpu_, lloyd_cpu_, still_cpu_, sweep_cpu_;
};

}  // namespace cvt::gui
