// Ctrl-C (SIGINT) and SIGTERM cancel the running stage instead of killing the process, so no
// temp file is left behind and the exit is clean. Stages check the flag often enough to stop
// within a second (tests/test_cancel.py); as a safety net, a watchdog ends the process itself
// (exit 130, one line) when the run has not stopped a quarter of a second after the signal
// (CVTMESH_CANCEL_GRACE_MS=N makes it N ms; the test makes it long). Nothing is on disk before
// the outputs are written, and the watchdog waits while they are (WritingOutputs).
#pragma once

#include <atomic>

namespace cvt::cli {

// Installs the handlers and the watchdog once; returns the flag they set (for
// Progress::cancel).
const std::atomic<bool>* install_interrupt_cancel();

// Called by the code that reports the cancel and exits: from then on the watchdog stays quiet.
void claim_interrupt_exit();

// While one is alive, the watchdog does not end the process: the outputs are being written
// (temp files exist) and are either finished and renamed or removed by their owner.
class WritingOutputs {
 public:
  WritingOutputs();
  ~WritingOutputs();
  WritingOutputs(const WritingOutputs&) = delete;
  WritingOutputs& operator=(const WritingOutputs&) = delete;
};

}  // namespace cvt::cli
