#include "pipeline_worker.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <new>

#include "base/threads.h"

namespace cvt::gui {
namespace {

pid_t thread_id() { return pid_t(syscall(SYS_gettid)); }

// The worker's nice value: 10 below the thread that made the worker (the UI thread), so the
// pipeline yields to the UI whatever the process was started with (nice -n -15 for a
// benchmark on a shared machine keeps the pipeline at -5, not below every other process).
int worker_nice() {
  errno = 0;
  const int ui = getpriority(PRIO_PROCESS, thread_id());
  return std::min((errno ? 0 : ui) + 10, 19);
}

// Sets the nice value of the calling thread only (Linux nice values are per thread).
void lower_thread_priority(int nice) { setpriority(PRIO_PROCESS, thread_id(), nice); }

// Lowers every TBB thread that joins the worker's arena, so pipeline work yields to the UI.
class NiceObserver : public tbb::task_scheduler_observer {
 public:
  NiceObserver(tbb::task_arena& arena, int nice)
      : tbb::task_scheduler_observer(arena), nice_(nice) {
    observe(true);
  }
  ~NiceObserver() override { observe(false); }
  void on_scheduler_entry(bool) override { lower_thread_priority(nice_); }

 private:
  int nice_;
};

// The first line of an exception message (the UI shows one line per error).
std::string one_line(const std::string& text) {
  const auto end = text.find('\n');
  return end == std::string::npos ? text : text.substr(0, end);
}

}  // namespace

PipelineWorker::PipelineWorker(int max_threads)
    : max_threads_(max_threads), nice_(worker_nice()), thread_([this] { thread_main(); }) {}

PipelineWorker::~PipelineWorker() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    queue_.clear();
  }
  cancel_ = true;
  wake_.notify_all();
  thread_.join();
}

void PipelineWorker::submit(std::string name, Job job) {
  {
    std::lock_guard lock(mutex_);
    queue_.emplace_back(std::move(name), std::move(job));
    status_.busy = true;
    status_.queued = queue_.size();
  }
  wake_.notify_one();
}

void PipelineWorker::cancel() {
  std::lock_guard lock(mutex_);
  queue_.clear();
  status_.queued = 0;
  // Only a running job can be cancelled; the flag is cleared when the next job starts.
  if (!status_.job.empty()) {
    cancel_ = true;
  } else {
    status_.busy = false;
    idle_.notify_all();
  }
}

bool PipelineWorker::busy() const {
  std::lock_guard lock(mutex_);
  return status_.busy;
}

WorkerStatus PipelineWorker::status() const {
  std::lock_guard lock(mutex_);
  WorkerStatus s = status_;
  if (!s.job.empty())
    s.elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - job_start_).count();
  return s;
}

std::optional<JobOutcome> PipelineWorker::take_outcome() {
  std::lock_guard lock(mutex_);
  if (outcomes_.empty()) return std::nullopt;
  JobOutcome o = std::move(outcomes_.front());
  outcomes_.pop_front();
  return o;
}

std::shared_ptr<const render::LloydState> PipelineWorker::take_lloyd_update() {
  std::lock_guard lock(mutex_);
  return std::exchange(lloyd_update_, nullptr);
}

void PipelineWorker::wait_idle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [this] { return !status_.busy; });
}

void PipelineWorker::thread_main() {
  lower_thread_priority(nice_);
  for (;;) {
    std::pair<std::string, Job> next;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      next = std::move(queue_.front());
      queue_.pop_front();
      status_ = {true, next.first, "", 0.0, 0.0, queue_.size()};
      job_start_ = std::chrono::steady_clock::now();
      cancel_ = false;
    }
    run_job(next.first, next.second);
    {
      std::lock_guard lock(mutex_);
      status_.job.clear();
      status_.step.clear();
      status_.busy = !queue_.empty();
      status_.queued = queue_.size();
      if (!status_.busy) idle_.notify_all();
    }
  }
}

void PipelineWorker::run_job(const std::string& name, const Job& job) {
  JobOutcome outcome;
  outcome.name = name;
  std::size_t lloyd_posted = pipeline_.lloyd() ? pipeline_.lloyd()->history().size() : 0;
  Progress progress;
  progress.cancel = &cancel_;
  const std::thread::id self = std::this_thread::get_id();
  progress.report = [&](const std::string& step, double fraction) {
    // On this thread, a report comes between pipeline steps (Lloyd reports before each
    // iteration), so a copy of the sites is a consistent intermediate state. A report from a
    // TBB thread inside a parallel loop only updates the progress text.
    const LloydStepper* lloyd = std::this_thread::get_id() == self ? pipeline_.lloyd() : nullptr;
    std::shared_ptr<const render::LloydState> update;
    if (lloyd && lloyd->history().size() != lloyd_posted) {
      lloyd_posted = lloyd->history().size();
      update = builder_.lloyd_state(*lloyd);
    }
    std::function<void()> notify;
    {
      std::lock_guard lock(mutex_);
      status_.step = step;
      status_.fraction = fraction;
      if (update) lloyd_update_ = std::move(update), notify = notify_;
    }
    if (notify) notify();
  };
  const auto t0 = std::chrono::steady_clock::now();
  // The run's own thread count wins over the viewer's cap (--threads).
  const int requested = pipeline_.parameters().threads;
  tbb::task_arena arena(resolve_threads(requested > 0 ? requested : max_threads_));
  NiceObserver nice(arena, nice_);
  arena.execute([&] {
    try {
      JobContext context{pipeline_, image_, progress};
      job(context);
    } catch (const Cancelled&) {
      outcome.status = JobOutcome::Status::cancelled;
    } catch (const std::bad_alloc&) {
      outcome.status = JobOutcome::Status::failed;
      outcome.error = name + ": out of memory";
    } catch (const std::exception& e) {
      outcome.status = JobOutcome::Status::failed;
      outcome.error = one_line(e.what());
    }
    // The snapshot shows whatever the pipeline holds now, also after a failure or a cancel
    // (earlier stages stay usable).
    const auto snapshot_start = std::chrono::steady_clock::now();
    try {
      outcome.scene = builder_.update(pipeline_, image_);
    } catch (const std::exception& e) {
      outcome.status = JobOutcome::Status::failed;
      outcome.error = std::string("preparing the view: ") + one_line(e.what());
      outcome.scene = builder_.last();
    }
    outcome.snapshot_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - snapshot_start).count();
  });
  outcome.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::lock_guard lock(mutex_);
  lloyd_update_.reset();  // the snapshot is newer
  // Queued jobs build on this one (the next stage, an export): after a failure or a cancel
  // they would only fail again, so they are dropped.
  if (outcome.status != JobOutcome::Status::ok) queue_.clear();
  outcomes_.push_back(std::move(outcome));
  if (notify_) notify_();
}

bool PipelineWorker::has_outcome() const {
  std::lock_guard lock(mutex_);
  return !outcomes_.empty();
}

void PipelineWorker::set_notify(std::function<void()> notify) {
  std::lock_guard lock(mutex_);
  notify_ = std::move(notify);
}

}  // namespace cvt::gui
