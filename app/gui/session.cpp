#include "session.h"

#include "io/image_io.h"
#include "io/mesh_export.h"
#include "pipeline/parameter_registry.h"
#include "pipeline/preset.h"

namespace cvt::gui {

Session::Session(const SessionOptions& options)
    : worker_(options.max_threads), recent_(options.recent_files_path) {
  recent_.load();
}

void Session::message(bool error, std::string text) {
  messages.push_back({error, std::move(text)});
  if (messages.size() > 200) messages.erase(messages.begin(), messages.begin() + 100);
}

void Session::open_image(const std::string& path) {
  worker_.submit("open " + path, [path, options = image_read_options(edited)](JobContext& ctx) {
    ctx.progress("reading " + path, 0.0);
    auto image = std::make_shared<const Image>(read_image(path, options));
    ctx.pipeline.set_image(image);
    ctx.image = std::move(image);
  });
}

namespace {

// The frame a NIfTI image is read in is a parameter: when the panel asks for another, the
// image is read again (which makes every stage stale).
void reread_if_frame_changed(JobContext& ctx, const Parameters& p) {
  const Image* image = ctx.image.get();
  if (!image || !image->nifti ||
      image->frame == frame_name(frame_in_use(*image->nifti, p.nifti_frame)))
    return;
  ctx.progress("reading " + image->source, 0.0);
  auto again = std::make_shared<const Image>(read_image(image->source, image_read_options(p)));
  ctx.pipeline.set_image(again);
  ctx.image = std::move(again);
}

// A grey image needs an iso value before stage 1 can run: without one, the middle of its value
// range (the UI shows the same default in the panel once the image is open).
Parameters with_default_iso(Parameters p, const Image* image) {
  if (!p.iso && image && !image->integer_valued) {
    const ValueRange r = value_range(*image);
    p.iso = 0.5 * (r.min + r.max);
  }
  return p;
}

}  // namespace

std::function<void(JobContext&)> Session::applying(std::function<void(JobContext&)> then) const {
  return [parameters = edited, then = std::move(then)](JobContext& ctx) {
    ctx.pipeline.set_pass_statistics(true);  // the panel plots every pass (~0.1 s a pass, liver)
    ctx.pipeline.set_evaluate_fidelity(true);  // the panel shows it
    reread_if_frame_changed(ctx, parameters);
    ctx.pipeline.set_parameters(with_default_iso(parameters, ctx.image.get()));
    then(ctx);
  };
}

void Session::submit_stage(Stage s) {
  worker_.submit(std::string(stage_name(s)), applying([s](JobContext& ctx) {
                   ctx.pipeline.run_through(s, ctx.progress);
                 }));
}

void Session::run_through(Stage last) {
  target_ = std::max(target_, last);
  for (int s = 0; s <= int(last); ++s) submit_stage(Stage(s));
}

void Session::run_all() {
  run_through(Stage::evaluate);
}

void Session::rerun_stale() {
  const auto stages = stages_to_rerun(stage_states(), target_);
  if (stages.empty() && edits_pending()) {
    // Only parameters that no stage depends on changed (threads, the guards): apply them.
    submit_stage(Stage::preprocess);
    return;
  }
  for (Stage s : stages) submit_stage(s);
}

void Session::run_next_stage() {
  const auto states = stage_states();
  for (int s = 0; s < kStageCount; ++s)
    if (states[s] != StageState::done) {
      target_ = std::max(target_, Stage(s));
      submit_stage(Stage(s));
      return;
    }
  message(false, "every stage is done");
}

void Session::step_lloyd(int iterations) {
  target_ = std::max(target_, Stage::cvt);
  const std::string name =
      iterations < 0 ? "Lloyd to convergence" : "Lloyd ×" + std::to_string(iterations);
  worker_.submit(name, applying([iterations](JobContext& ctx) {
                   ctx.pipeline.step_lloyd(iterations, ctx.progress);
                 }));
}

void Session::step_optimization(int passes) {
  target_ = std::max(target_, Stage::optimize);
  if (edited.optimize != OptimizeMode::standard) {
    edited.optimize = OptimizeMode::standard;
    message(false, "optimisation turned on (optimize = " +
                       std::string(optimize_word(OptimizeMode::standard)) + ")");
  }
  const int jobs = passes < 0 ? std::max(edited.optimization.max_passes, 1) : passes;
  for (int i = 0; i < jobs; ++i)
    worker_.submit("optimisation pass", applying([](JobContext& ctx) {
                     ctx.pipeline.step_optimization(1, ctx.progress);
                   }));
}

void Session::cancel() {
  worker_.cancel();
}

void Session::export_mesh(const std::string& path) {
  worker_.submit("export " + path, [path](JobContext& ctx) {
    const TetMesh* mesh = ctx.pipeline.final_mesh();
    if (!mesh) throw InputError("no mesh to export yet: run mesh generation first");
    ctx.progress("writing " + path, 0.0);
    write_mesh_with_quality(*mesh, path);
  });
}

bool Session::load_preset(const std::string& path) {
  try {
    edited = cvt::load_preset(path, edited);
  } catch (const std::exception& e) {
    message(true, e.what());
    return false;
  }
  message(false, "loaded preset " + path);
  last_edit_s_ = -1e9;  // a preset is a deliberate change: auto re-run may start at once
  return true;
}

bool Session::save_preset(const std::string& path) {
  try {
    validate(edited);
    cvt::save_preset(edited, path);
  } catch (const std::exception& e) {
    message(true, e.what());
    return false;
  }
  message(false, "saved preset " + path);
  return true;
}

void Session::parameters_edited(double now_s) {
  last_edit_s_ = now_s;
}

std::shared_ptr<const render::LloydState> Session::lloyd() const {
  if (live_lloyd_) return live_lloyd_;
  return scene_ ? scene_->lloyd : nullptr;
}

std::array<StageState, kStageCount> Session::stage_states() const {
  return cvt::gui::stage_states(scene_.get(), edited);
}

bool Session::poll(double now_s) {
  bool changed = false;
  if (auto update = worker_.take_lloyd_update()) {
    live_lloyd_ = std::move(update);
    changed = true;
  }
  while (auto outcome = worker_.take_outcome()) {
    changed = true;
    job_times.push_back({outcome->name, outcome->wall_s, outcome->snapshot_s});
    const bool new_image = outcome->scene && (!scene_ || scene_->generations.image !=
                                                             outcome->scene->generations.image);
    scene_ = outcome->scene;
    live_lloyd_.reset();
    switch (outcome->status) {
      case JobOutcome::Status::ok:
        if (outcome->name.rfind("open ", 0) == 0) {
          image_path = outcome->name.substr(5);
          recent_.add(image_path);
          message(false, "opened " + image_path);
        } else if (outcome->name.rfind("export ", 0) == 0) {
          message(false, "wrote " + outcome->name.substr(7));
        }
        break;
      case JobOutcome::Status::cancelled:
        message(false, outcome->name + ": cancelled");
        break;
      case JobOutcome::Status::failed:
        if (failed_jobs++ == 0) first_error = outcome->error;
        message(true, outcome->error);
        break;
    }
    if (new_image && scene_->image)
      for (const std::string& warning : scene_->image->warnings)
        message(false, "warning: " + warning);
    // A grey image: show the iso value the runs default to (with_default_iso), to adjust.
    if (new_image && scene_ && scene_->image && !scene_->image->integer_valued && !edited.iso) {
      edited = with_default_iso(edited, scene_->image.get());
      message(false, "grey image: iso value set to mid range; adjust it in the pipeline panel");
    }
  }
  // Auto re-run: once per set of edited values (a failing run is not retried in a loop), and
  // only for values that validate (the panel shows what is wrong meanwhile).
  if (should_auto_rerun(auto_rerun, edits_pending(), worker_.busy(), now_s - last_edit_s_) &&
      !(auto_tried_ && *auto_tried_ == edited)) {
    auto_tried_ = edited;
    try {
      validate(edited);
      rerun_stale();
    } catch (const InputError&) {
    }
  }
  return changed;
}

}  // namespace cvt::gui
