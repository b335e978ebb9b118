// Ctrl-C (SIGINT) and SIGTERM cancel the running stage instead of killing the process, so no
// temp file is left behind and the exit is clean.
#pragma once

#include <atomic>

namespace cvt::cli {

// Installs the handlers once; returns the flag they set (for Progress::cancel).
const std::atomic<bool>* install_interrupt_cancel();

}  // namespace cvt::cli
