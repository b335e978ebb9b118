// Progress reporting and cancellation shared by every stage; the CLI prints it, the viewer
// shows it and sets `cancel` from its UI thread.
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "base/errors.h"

namespace cvt {

struct Progress {
  std::function<void(const std::string& step, double fraction)> report;  // may be empty
  const std::atomic<bool>* cancel = nullptr;                            // may be null

  void operator()(const std::string& step, double fraction) const {
    check_cancelled();
    if (report) report(step, fraction);
  }
  void check_cancelled() const {
    if (cancel && cancel->load(std::memory_order_relaxed)) throw Cancelled();
  }
};

}  // namespace cvt
