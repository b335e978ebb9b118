// The viewer's state apart from drawing: the worker and its snapshots, the parameters as
// edited in the panel, messages, recent files, and the actions the panels, the keyboard and
// the scripted mode trigger. Runs on the UI thread; every pipeline operation becomes a job on
// the worker. GL-free, so the control flow is unit tested without a window.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pipeline_worker.h"
#include "recent_files.h"
#include "view_settings.h"

namespace cvt::gui {

struct Message {
  bool error = false;
  std::string text;
};

struct SessionOptions {
  int max_threads = 0;            // TBB threads of a job (0 = all cores)
  std::string recent_files_path;  // empty: recent files are not kept
};

class Session {
 public:
  explicit Session(const SessionOptions& options = {});

  // Actions. Every run applies `edited` to the pipeline first, so what runs is what the panel
  // shows. Runs are one job per stage, so each finished stage is drawn while the next runs.
  void open_image(const std::string& path);
  void run_all();
  void run_through(Stage last);
  void rerun_stale();               // the non-done stages up to the furthest asked for
  void run_next_stage();            // the first non-done stage
  void step_lloyd(int iterations);  // < 0: to convergence
  // Stage 6 pass by pass, one job per pass so the views follow each one: `passes` jobs (< 0:
  // as many as edited.optimization.max_passes; those after the last useful pass do nothing).
  // Turns optimisation on (edited.optimize = standard): stepping it means using it.
  void step_optimization(int passes);
  void cancel();
  void export_mesh(const std::string& path);
  // Presets are read and written on the UI thread (small files); errors become messages.
  bool load_preset(const std::string& path);
  bool save_preset(const std::string& path);
  // Call after the panel changed `edited`; `now_s` is any monotonic clock in seconds.
  void parameters_edited(double now_s);

  // Per frame: takes finished jobs and live Lloyd states, runs the auto re-run. True when
  // something to draw changed.
  bool poll(double now_s);

  const render::SceneData* scene() const { return scene_.get(); }
  std::shared_ptr<const render::SceneData> scene_ptr() const { return scene_; }
  // The newest Lloyd state: a live one posted during a job, else the snapshot's.
  std::shared_ptr<const render::LloydState> lloyd() const;
  std::array<StageState, kStageCount> stage_states() const;
  bool edits_pending() const {
    return first_edited_stage(scene_.get(), edited) != Stage::count;
  }
  WorkerStatus worker_status() const { return worker_.status(); }
  bool busy() const { return worker_.busy(); }
  bool has_finished_job() const { return worker_.has_outcome(); }
  // See PipelineWorker::set_notify.
  void set_notify(std::function<void()> notify) { worker_.set_notify(std::move(notify)); }
  void wait_idle() { worker_.wait_idle(); }

  Parameters edited;  // what the pipeline panel shows and edits (stage 6's options too)
  bool auto_rerun = false;
  std::vector<Message> messages;  // newest last
  std::size_t failed_jobs = 0;
  std::string first_error;  // the first failure (the cause of any that follow), for scripted
                            // mode's exit line
  std::string image_path;   // the last image opened successfully
  const RecentFiles& recent() const { return recent_; }
  // Every finished job: name, seconds in all, seconds of it spent on the snapshot.
  struct JobTime {
    std::string name;
    double wall_s = 0, snapshot_s = 0;
  };
  std::vector<JobTime> job_times;

 private:
  void submit_stage(Stage s);
  // The job's first step: the edited parameters and stage 6 options, applied to the pipeline.
  std::function<void(JobContext&)> applying(std::function<void(JobContext&)> then) const;
  void message(bool error, std::string text);

  PipelineWorker worker_;
  RecentFiles recent_;
  std::shared_ptr<const render::SceneData> scene_;
  std::shared_ptr<const render::LloydState> live_lloyd_;
  Stage target_ = Stage::preprocess;  // the furthest stage asked for
  double last_edit_s_ = -1e9;
  std::optional<Parameters> auto_tried_;  // the values auto re-run last started with
};

}  // namespace cvt::gui
