#include "frame_stats.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>

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

double render_cpu_ms() {
  namespace fs = std::filesystem;
  auto run_ns = [](const fs::path& task) {
    std::ifstream in(task / "schedstat");
    double ns = -1;
    in >> ns;
    return ns;
  };
  std::error_code ec;
  const double own = run_ns(fs::path("/proc/thread-self"));
  if (own < 0) return -1;
  double ns = own;
  for (fs::directory_iterator it("/proc/self/task", ec), end; !ec && it != end; it.increment(ec)) {
    std::ifstream comm(it->path() / "comm");
    std::string name;
    std::getline(comm, name);
    if (name.rfind("llvmpipe", 0) == 0) ns += std::max(run_ns(it->path()), 0.0);
  }
  return ns * 1e-6;
}

void BenchmarkRecorder::record(double ms, const std::string& job, bool ready, double cpu_ms) {
  auto keep = [cpu_ms](std::vector<double>& wall, std::vector<double>& cpu, double w) {
    wall.push_back(w);
    if (cpu_ms >= 0) cpu.push_back(cpu_ms);
  };
  if (!job.empty()) {
    keep(busy_, busy_cpu_, ms);
    if (job == "CVT sampling" || job.rfind("Lloyd", 0) == 0) keep(lloyd_, lloyd_cpu_, ms);
    return;
  }
  if (!ready || done()) return;
  if (recorded_ < frames_)
    keep(still_, still_cpu_, ms);
  else
    keep(sweep_, sweep_cpu_, ms);
  ++recorded_;
}

double BenchmarkRecorder::sweep_position() const {
  if (recorded_ < frames_ || done()) return -1;
  return 0.3 + 0.4 * double(recorded_ - frames_) / double(std::max(frames_ - 1, 1));
}

std::string BenchmarkRecorder::report() const {
  std::string out;
  auto phase = [&out](const std::string& label, const std::vector<double>& wall,
                      const std::vector<double>& cpu) {
    out += describe(label, frame_stats(wall)) + "\n";
    if (!cpu.empty()) out += describe(label + " (CPU)", frame_stats(cpu)) + "\n";
  };
  phase("while jobs ran", busy_, busy_cpu_);
  phase("  of which during Lloyd iterations", lloyd_, lloyd_cpu_);
  phase("static view", still_, still_cpu_);
  phase("clip plane moving (cut-away rebuilt every frame)", sweep_, sweep_cpu_);
  return out;
}

}  // namespace cvt::gui
