#include "signal_cancel.h"

#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <thread>

namespace cvt::cli {
namespace {

// The watchdog's grace: 250 ms, or CVTMESH_CANCEL_GRACE_MS (tests make it long, to time the
// stages' own checks).
std::chrono::milliseconds grace() {
  const char* ms = std::getenv("CVTMESH_CANCEL_GRACE_MS");
  return std::chrono::milliseconds(ms && *ms ? std::atol(ms) : 250);
}
constexpr char kMessage[] = "cvtmesh: cancelled; nothing was written\n";

std::atomic<bool> interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
int wake_pipe[2] = {-1, -1};  // the handler writes a byte; the watchdog reads it

std::mutex state_mutex;
bool exit_claimed = false;  // someone reports the cancel and exits: the watchdog stays quiet
int writing = 0;            // WritingOutputs alive

extern "C" void on_interrupt(int) {
  const int saved = errno;
  interrupted.store(true);
  const char byte = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_pipe[1], &byte, 1);  // async-signal-safe
  errno = saved;
}

void watchdog() {
  char byte;
  while (::read(wake_pipe[0], &byte, 1) < 0 && errno == EINTR) {
  }
  std::this_thread::sleep_for(grace());
  for (;;) {
    {
      std::lock_guard lock(state_mutex);
      if (exit_claimed) return;
      if (writing == 0) {
        exit_claimed = true;
        std::fputs(kMessage, stderr);
        std::fflush(stderr);
        ::_exit(130);  // no destructors: nothing is on disk yet and the OS frees the rest
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace

const std::atomic<bool>* install_interrupt_cancel() {
  static const bool installed = [] {
    if (::pipe(wake_pipe) == 0) std::thread(watchdog).detach();
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
    return true;
  }();
  (void)installed;
  return &interrupted;
}

void claim_interrupt_exit() {
  std::lock_guard lock(state_mutex);
  exit_claimed = true;
}

WritingOutputs::WritingOutputs() {
  std::lock_guard lock(state_mutex);
  ++writing;
}

WritingOutputs::~WritingOutputs() {
  std::lock_guard lock(state_mutex);
  --writing;
}

}  // namespace cvt::cli
