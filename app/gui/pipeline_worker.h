// The viewer's worker thread. It owns the Pipeline (which is not thread-safe): jobs run one at a
// time, in order, with exclusive use of it, and after each job the worker builds an immutable
// SceneData snapshot that the UI thread takes and draws. During Lloyd iterations it also posts
// the sites after every iteration, so the views follow the optimisation live. The UI thread
// never touches the Pipeline. Cancel sets the atomic flag Progress checks. GL-free.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "pipeline/pipeline.h"
#include "scene_data.h"

namespace cvt::gui {

// What a job gets: the pipeline, the current image (a job that opens a file replaces it) and
// the progress to pass to every pipeline call.
struct JobContext {
  Pipeline& pipeline;
  std::shared_ptr<const Image>& image;
  const Progress& progress;
};
using Job = std::function<void(JobContext&)>;

struct JobOutcome {
  enum class Status { ok, cancelled, failed };
  std::string name;
  Status status = Status::ok;
  std::string error;                               // one line, when failed
  double wall_s = 0;                               // the whole job, snapshot included
  double snapshot_s = 0;                           // building the snapshot (copies for the views)
  std::shared_ptr<const render::SceneData> scene;  // the pipeline after the job
};

struct WorkerStatus {
  bool busy = false;    // a job runs or waits
  std::string job;      // the running job's name
  std::string step;     // its last progress message
  double fraction = 0;  // its last progress fraction
  double elapsed_s = 0;
  std::size_t queued = 0;  // jobs waiting behind it
};

class PipelineWorker {
 public:
  // max_threads: TBB threads a job may use (0 = all cores). The worker's threads run at a lower
  // priority (nice + 10 relative to the calling thread) so the UI thread and the GL driver stay
  // responsive.
  explicit PipelineWorker(int max_threads = 0);
  ~PipelineWorker();  // cancels, drops queued jobs, joins
  PipelineWorker(const PipelineWorker&) = delete;
  PipelineWorker& operator=(const PipelineWorker&) = delete;

  void submit(std::string name, Job job);
  // Stops the running job at its next progress check and drops the queued ones.
  void cancel();
  bool busy() const;
  WorkerStatus status() const;
  // Finished jobs, oldest first.
  std::optional<JobOutcome> take_outcome();
  // The Lloyd state posted after the latest iteration since the last call (null if none).
  std::shared_ptr<const render::LloydState> take_lloyd_update();
  // Blocks until no job runs or waits (tests and scripted runs).
  void wait_idle();
  // Whether a finished job waits to be taken.
  bool has_outcome() const;
  // Called (on the worker thread) when a job ends or a Lloyd state is posted, so the UI can
  // wake up for it: GLFW's glfwPostEmptyEvent, which may be called from any thread.
  void set_notify(std::function<void()> notify);

 private:
  void thread_main();
  void run_job(const std::string& name, const Job& job);

  int max_threads_;
  int nice_;  // of the worker's threads
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::deque<std::pair<std::string, Job>> queue_;
  std::deque<JobOutcome> outcomes_;
  std::shared_ptr<const render::LloydState> lloyd_update_;
  std::function<void()> notify_;
  WorkerStatus status_;
  std::chrono::steady_clock::time_point job_start_;
  std::atomic<bool> cancel_{false};
  bool stop_ = false;
  // Owned by the worker thread only.
  Pipeline pipeline_;
  std::shared_ptr<const Image> image_;
  render::SceneDataBuilder builder_;
  std::thread thread_;  // last: starts after everything above exists
};

}  // namespace cvt::gui
