// The viewer's GL-free control logic (app/gui/): stale marking and re-run decisions, view
// layout, the worker thread (order, cancel, failures, live Lloyd states), the session driving
// a real pipeline (stage 6 pass by pass too), recent files, parameter tooltips, frame
// statistics, and every user input (command line, File > Open, drops, recent files, keys)
// through the functions the window calls. No window (GLFW's header for its key codes only).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "frame_stats.h"
#include "input_actions.h"
#include "io/image_io.h"
#include "pipeline/parameter_registry.h"
#include "phantoms.h"
#include "pipeline_worker.h"
#include "pipeline/preset.h"
#include "recent_files.h"
#include "session.h"
#include "view_settings.h"

using namespace cvt;
using namespace cvt::gui;

namespace {

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("cvtmesh_gui_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// A small torus image on disk, as a user would open it.
std::string torus_file() {
  static const std::string path = [] {
    const Phantom p = torus_phantom({4, -3, 2}, 9.0, 3.5);
    const Image img =
        rasterize(p, grid_around(p, {0.7, 0.8, 1.0}, rotation_matrix({1, 0, 1}, 0.3)));
    const std::string file = (temp_dir("images") / "torus.nii.gz").string();
    write_image(img, file);
    return file;
  }();
  return path;
}

// Polls until the worker is idle and every outcome is taken.
void settle(Session& s) {
  s.wait_idle();
  s.poll(0);
}

render::SceneData scene_with(const Parameters& applied, std::array<bool, kStageCount> stale) {
  render::SceneData scene;
  scene.parameters = applied;
  scene.stale = stale;
  return scene;
}

}  // namespace

TEST(ViewSettings, StageStatesMarkEditsAndStaleness) {
  Parameters applied;
  auto scene = scene_with(applied, {false, false, false, false, false, false});
  Parameters edited = applied;
  auto states = stage_states(&scene, edited);
  for (StageState s : states) EXPECT_EQ(s, StageState::done);
  edited.r = 0.3;  // surface sampling and everything after it
  states = stage_states(&scene, edited);
  EXPECT_EQ(states[0], StageState::done);
  for (int s = 1; s < kStageCount; ++s) EXPECT_EQ(states[s], StageState::pending) << s;
  EXPECT_EQ(first_edited_stage(&scene, edited), Stage::surface);
  edited = applied;
  edited.seed = 7;
  EXPECT_EQ(first_edited_stage(&scene, edited), Stage::cvt);
  // The pipeline's own staleness shows whatever the edits.
  scene = scene_with(applied, {false, false, false, true, true, true});
  states = stage_states(&scene, applied);
  EXPECT_EQ(states[2], StageState::done);
  EXPECT_EQ(states[3], StageState::stale);
  for (StageState s : stage_states(nullptr, applied)) EXPECT_EQ(s, StageState::stale);
}

TEST(ViewSettings, RerunAndAutoRerunDecisions) {
  std::array<StageState, kStageCount> states{StageState::done,    StageState::pending,
                                             StageState::pending, StageState::stale,
                                             StageState::stale,   StageState::stale};
  EXPECT_EQ(stages_to_rerun(states, Stage::cvt), (std::vector<Stage>{Stage::surface, Stage::cvt}));
  EXPECT_EQ(stages_to_rerun(states, Stage::evaluate).size(), 5u);
  states.fill(StageState::done);
  EXPECT_TRUE(stages_to_rerun(states, Stage::evaluate).empty());
  EXPECT_TRUE(should_auto_rerun(true, true, false, 1.0));
  EXPECT_FALSE(should_auto_rerun(false, true, false, 1.0));  // off
  EXPECT_FALSE(should_auto_rerun(true, false, false, 1.0));  // nothing to do
  EXPECT_FALSE(should_auto_rerun(true, true, true, 1.0));    // a job runs
  EXPECT_FALSE(should_auto_rerun(true, true, false, 0.1));   // still dragging a slider
}

TEST(ViewSettings, LayoutModesAndPoints) {
  ViewMode m;
  EXPECT_TRUE(parse_view_mode("3d", m));
  EXPECT_EQ(m, ViewMode::view3d);
  EXPECT_FALSE(parse_view_mode("4d", m));
  const Rect area = views_area(1280, 800, 370, 390, 20, 28);
  EXPECT_FLOAT_EQ(area.x, 370);
  EXPECT_FLOAT_EQ(area.w, 1280 - 370 - 390);
  EXPECT_FLOAT_EQ(area.h, 800 - 48);
  const ViewRects tall = view_rects(ViewMode::split, area);  // 520 × 752: one above the other
  EXPECT_FLOAT_EQ(tall.view3d.h + tall.slice.h, area.h);
  EXPECT_FLOAT_EQ(tall.slice.y, tall.view3d.y + tall.view3d.h);
  EXPECT_FLOAT_EQ(tall.slice.w, area.w);
  const Rect wide_area{0, 20, 1280, 752};
  const ViewRects wide = view_rects(ViewMode::split, wide_area);  // side by side
  EXPECT_FLOAT_EQ(wide.view3d.w + wide.slice.w, wide_area.w);
  EXPECT_FLOAT_EQ(wide.slice.x, wide.view3d.x + wide.view3d.w);
  EXPECT_TRUE(wide.slice.contains(wide_area.w - 1, wide_area.y + 1));
  EXPECT_TRUE(view_rects(ViewMode::slice, area).view3d.empty());
  // Panels wider than the window leave the views the whole window.
  EXPECT_FLOAT_EQ(views_area(600, 400, 370, 390, 0, 0).w, 600);

  ViewSettings v;
  PointsShown p = points_shown_3d(v, true, false);  // surface, no mesh, no clip
  EXPECT_TRUE(p.samples);
  EXPECT_FALSE(p.interior);  // hidden inside the surface
  v.clip_enabled = true;
  EXPECT_TRUE(points_shown_3d(v, true, false).interior);
  p = points_shown_3d(v, true, true);  // the mesh's vertices are B and I
  EXPECT_FALSE(p.samples);
  EXPECT_FALSE(p.interior);
  EXPECT_FALSE(p.shallow);  // inside the kept tets
  v.overlays.poles = true;
  EXPECT_TRUE(points_shown_3d(v, true, true).poles);
  v.show_surface = false;  // the mesh hidden: every point shows
  p = points_shown_3d(v, true, true);
  EXPECT_TRUE(p.samples && p.interior && p.shallow && p.poles);
  v.show_points = false;
  EXPECT_FALSE(points_shown_3d(v, true, true).poles);
}

TEST(ViewSettings, SliceIndexDefaultsToTheObject) {
  render::SceneData scene;
  ViewSettings v;
  EXPECT_EQ(effective_slice_index(v, scene), 0);
  auto image = std::make_shared<Image>();
  image->voxels.grid.dims = {10, 20, 30};
  scene.image = image;
  EXPECT_EQ(effective_slice_index(v, scene), 15);
  auto vol = std::make_shared<render::VolumeLayers>();
  vol->grid.dims = {4, 4, 6};
  vol->offset = {2, 3, 20};
  scene.volumes = vol;
  EXPECT_EQ(effective_slice_index(v, scene), 23);
  v.slice_index = 7;
  EXPECT_EQ(effective_slice_index(v, scene), 7);
  v.slice_index = 99;  // out of range: back to the default
  EXPECT_EQ(effective_slice_index(v, scene), 23);
}

TEST(RecentFiles, MostRecentFirstNoDuplicatesPersisted) {
  const auto file = temp_dir("recent") / "sub" / "recent.txt";
  std::filesystem::remove(file);
  {
    RecentFiles r(file.string(), 3);
    r.load();
    EXPECT_TRUE(r.files().empty());
    EXPECT_TRUE(r.add("/data/a.nii"));
    r.add("/data/b.nii");
    r.add("/data/a.nii");
    r.add("/data/c.nii");
    r.add("/data/d.nii");
    EXPECT_EQ(r.files(), (std::vector<std::string>{"/data/d.nii", "/data/c.nii", "/data/a.nii"}));
  }
  RecentFiles again(file.string(), 3);
  again.load();
  EXPECT_EQ(again.files().front(), "/data/d.nii");
  EXPECT_EQ(again.files().size(), 3u);
  RecentFiles nowhere("", 3);
  EXPECT_FALSE(nowhere.add("x"));
}

TEST(FrameStats, Summary) {
  const FrameStats s = frame_stats({10, 20, 30, 40, 120});
  EXPECT_EQ(s.frames, 5u);
  EXPECT_DOUBLE_EQ(s.mean_ms, 44);
  EXPECT_DOUBLE_EQ(s.median_ms, 30);
  EXPECT_DOUBLE_EQ(s.max_ms, 120);
  EXPECT_EQ(s.over_50ms, 1u);
  EXPECT_EQ(s.over_100ms, 1u);
  EXPECT_EQ(frame_stats({}).frames, 0u);
  EXPECT_NE(describe("x", s).find("max 120.0 ms"), std::string::npos);
}

TEST(FrameStats, BenchmarkPhases) {
  BenchmarkRecorder b(3);
  b.record(40, "CVT sampling", false);
  b.record(20, "preprocess", false);
  b.record(5, "", false);  // idle but not yet drawn: not counted
  EXPECT_LT(b.sweep_position(), 0);
  for (int i = 0; i < 3; ++i) b.record(10, "", true, 4);
  EXPECT_DOUBLE_EQ(b.sweep_position(), 0.3);  // the sweep starts
  for (int i = 0; i < 3; ++i) b.record(12, "", true);
  EXPECT_TRUE(b.done());
  const std::string report = b.report();
  EXPECT_NE(report.find("while jobs ran: 2 frames"), std::string::npos) << report;
  EXPECT_NE(report.find("during Lloyd iterations: 1 frames"), std::string::npos) << report;
  EXPECT_NE(report.find("static view: 3 frames, mean 10.0 ms"), std::string::npos) << report;
  EXPECT_NE(report.find("rebuilt every frame): 3 frames, mean 12.0 ms"), std::string::npos)
      << report;
  // CPU times where given.
  EXPECT_NE(report.find("static view (CPU): 3 frames, mean 4.0 ms"), std::string::npos) << report;
  EXPECT_EQ(report.find("while jobs ran (CPU)"), std::string::npos) << report;
  // This thread's CPU time grows with work.
  const double c0 = render_cpu_ms();
  ASSERT_GE(c0, 0);
  volatile double x = 0;
  for (int i = 0; i < 20000000; ++i) x = x + 1e-9 * i;
  EXPECT_GT(render_cpu_ms(), c0);
}

TEST(PipelineWorker, RunsInOrderCancelsAndDropsAfterAFailure) {
  PipelineWorker worker(1);
  std::vector<int> order;
  for (int i = 0; i < 3; ++i)
    worker.submit("job" + std::to_string(i), [&order, i](JobContext&) { order.push_back(i); });
  worker.wait_idle();
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2}));
  for (int i = 0; i < 3; ++i) {
    auto o = worker.take_outcome();
    ASSERT_TRUE(o);
    EXPECT_EQ(o->status, JobOutcome::Status::ok);
    EXPECT_NE(o->scene, nullptr);  // every job leaves a snapshot
  }
  EXPECT_FALSE(worker.take_outcome());

  // A failure drops what was queued behind it; its message is one line. The failing job waits
  // until the next one is queued: otherwise it may fail first, leaving nothing to drop.
  std::atomic<bool> queued{false};
  worker.submit("bad", [&queued](JobContext&) {
    while (!queued) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    throw InputError("file x: broken\nsecond line");
  });
  worker.submit("after", [&order](JobContext&) { order.push_back(99); });
  queued = true;
  worker.wait_idle();
  auto bad = worker.take_outcome();
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, JobOutcome::Status::failed);
  EXPECT_EQ(bad->error, "file x: broken");
  EXPECT_FALSE(worker.take_outcome());
  EXPECT_EQ(order.back(), 2);

  // Cancel stops a running job at its next progress check and drops the queue.
  std::atomic<bool> started{false};
  worker.submit("long", [&started](JobContext& ctx) {
    started = true;
    for (;;) {
      ctx.progress("spinning", 0.5);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  worker.submit("queued", [&order](JobContext&) { order.push_back(100); });
  while (!started) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_TRUE(worker.busy());
  EXPECT_EQ(worker.status().job, "long");
  worker.cancel();
  worker.wait_idle();
  auto cancelled = worker.take_outcome();
  ASSERT_TRUE(cancelled);
  EXPECT_EQ(cancelled->status, JobOutcome::Status::cancelled);
  EXPECT_FALSE(worker.take_outcome());
  EXPECT_EQ(order.back(), 2);
  EXPECT_FALSE(worker.busy());
}

TEST(Session, OpensRunsStepsAndKeepsTheLastGoodStateAfterErrors) {
  Session s;
  s.open_image(torus_file());
  s.run_through(Stage::surface);
  settle(s);
  ASSERT_NE(s.scene(), nullptr);
  EXPECT_EQ(s.failed_jobs, 0u);
  EXPECT_EQ(s.image_path, torus_file());
  ASSERT_NE(s.scene()->surface_samples, nullptr);
  EXPECT_EQ(s.scene()->mesh, nullptr);

  // Lloyd steps post a live state per iteration; the final snapshot has all iterations.
  s.step_lloyd(3);
  settle(s);
  ASSERT_NE(s.lloyd(), nullptr);
  EXPECT_EQ(s.lloyd()->history.size(), 3u);

  s.run_all();
  settle(s);
  ASSERT_NE(s.scene()->mesh, nullptr);
  ASSERT_NE(s.scene()->quality, nullptr);
  for (StageState st : s.stage_states()) EXPECT_EQ(st, StageState::done);

  // An edit marks stages pending without touching the pipeline; re-run applies and runs them.
  const auto mesh_before = s.scene()->mesh;
  s.edited.seed = 5;
  EXPECT_TRUE(s.edits_pending());
  EXPECT_EQ(s.stage_states()[int(Stage::surface)], StageState::done);
  EXPECT_EQ(s.stage_states()[int(Stage::cvt)], StageState::pending);
  EXPECT_EQ(s.scene()->mesh, mesh_before);  // still drawn while pending
  s.rerun_stale();
  settle(s);
  EXPECT_FALSE(s.edits_pending());
  ASSERT_NE(s.scene()->mesh, nullptr);
  EXPECT_NE(s.scene()->mesh, mesh_before);

  // A bad file fails with a message; the previous image and results stay.
  const auto scene_before = s.scene_ptr();
  s.open_image("/nonexistent/liver.nii.gz");
  settle(s);
  EXPECT_EQ(s.failed_jobs, 1u);
  EXPECT_TRUE(s.messages.back().error);
  EXPECT_NE(s.first_error.find("/nonexistent/liver.nii.gz"), std::string::npos);
  ASSERT_NE(s.scene(), nullptr);
  EXPECT_EQ(s.scene()->mesh, scene_before->mesh);
  EXPECT_EQ(s.image_path, torus_file());

  // Export through the worker.
  const std::string out = (temp_dir("export") / "torus.vtu").string();
  s.export_mesh(out);
  settle(s);
  EXPECT_TRUE(std::filesystem::exists(out));

  // A preset round trip on the UI thread.
  const std::string preset = (temp_dir("preset") / "p.json").string();
  s.edited.r = 0.35;
  EXPECT_TRUE(s.save_preset(preset));
  s.edited.r = 0.5;
  EXPECT_TRUE(s.load_preset(preset));
  EXPECT_DOUBLE_EQ(s.edited.r, 0.35);
  EXPECT_FALSE(s.load_preset("/nonexistent.json"));
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// File > Export writes what `cvtmesh mesh -o` writes: the committed phantom with default
// parameters and the same thread count, through the CLI binary and through the session, give
// the same .vtu byte for byte (mesh, labels and the quality cell data).
TEST(Session, ExportWritesTheFileTheCommandLineWrites) {
  const std::string image = CVTMESH_SOURCE_DIR "/assets/phantom_torus.nii.gz";
  const auto dir = temp_dir("same_export");
  const std::string cli = (dir / "cli.vtu").string(), viewer = (dir / "viewer.vtu").string();
  const std::string command =
      std::string("'") + CVTMESH_CLI + "' mesh '" + image + "' -o '" + cli + "' --threads 2 -q";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  Session s;
  s.edited.threads = 2;
  s.open_image(image);
  s.run_all();
  s.export_mesh(viewer);
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  const std::string written = file_bytes(viewer);
  EXPECT_GT(written.size(), 10000u);
  EXPECT_NE(written.find("Name=\"min_dihedral_deg\""), std::string::npos);
  EXPECT_TRUE(written == file_bytes(cli)) << cli << " and " << viewer << " differ";
}

TEST(Session, AutoRerunStartsOnceAfterAQuietEdit) {
  Session s;
  s.open_image(torus_file());
  s.run_through(Stage::surface);
  settle(s);
  s.auto_rerun = true;
  s.edited.r = 0.3;
  s.parameters_edited(100.0);
  s.poll(100.1);  // too soon after the edit
  EXPECT_FALSE(s.busy());
  s.poll(101.0);
  s.wait_idle();
  s.poll(101.1);
  EXPECT_FALSE(s.edits_pending());
  EXPECT_DOUBLE_EQ(s.scene()->parameters.r, 0.3);
  // An invalid value is not run (and not retried in a loop).
  s.edited.r = 3.0;
  s.parameters_edited(102.0);
  s.poll(110.0);
  EXPECT_FALSE(s.busy());
  EXPECT_EQ(s.failed_jobs, 0u);
}

TEST(PipelineWorker, PostsTheSitesAfterEachLloydIteration) {
  PipelineWorker worker(1);
  std::atomic<bool> stepped{false}, release{false};
  worker.submit("steps", [&](JobContext& ctx) {
    auto image = std::make_shared<const Image>(read_image(torus_file()));
    ctx.pipeline.set_image(image);
    ctx.image = image;
    ctx.pipeline.step_lloyd(3, ctx.progress);
    stepped = true;
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  while (!stepped) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  // Reported before iterations 2 and 3: the newest is the state after iteration 2, while the
  // job still runs (the UI draws it without touching the pipeline).
  const auto live = worker.take_lloyd_update();
  ASSERT_NE(live, nullptr);
  EXPECT_EQ(live->history.size(), 2u);
  EXPECT_FALSE(live->sites_world.empty());
  EXPECT_EQ(worker.take_lloyd_update(), nullptr);  // taken
  release = true;
  worker.wait_idle();
  const auto done = worker.take_outcome();
  ASSERT_TRUE(done);
  ASSERT_NE(done->scene->lloyd, nullptr);
  EXPECT_EQ(done->scene->lloyd->history.size(), 3u);
}

// The viewer paces its frames while a job runs and wakes up for what it must show at once:
// the worker tells it when a Lloyd state is posted and when a job ends.
TEST(PipelineWorker, NotifiesLloydStatesAndFinishedJobs) {
  PipelineWorker worker(1);
  std::atomic<int> notified{0};
  worker.set_notify([&] { ++notified; });
  worker.submit("steps", [&](JobContext& ctx) {
    auto image = std::make_shared<const Image>(read_image(torus_file()));
    ctx.pipeline.set_image(image);
    ctx.image = image;
    ctx.pipeline.step_lloyd(3, ctx.progress);  // states posted before iterations 2 and 3
  });
  worker.wait_idle();
  EXPECT_TRUE(worker.has_outcome());
  EXPECT_EQ(notified.load(), 3);  // two Lloyd states, one finished job
  ASSERT_TRUE(worker.take_outcome());
  EXPECT_FALSE(worker.has_outcome());
}

TEST(Session, GreyImagesGetAnIsoValue) {
  // The torus as grey values 0..200 (float), no iso given anywhere.
  const Phantom p = torus_phantom({0, 0, 0}, 9.0, 3.5);
  Image grey = rasterize(p, grid_around(p, {0.8, 0.8, 1.0}, rotation_matrix({0, 0, 1}, 0)));
  for (float& v : grey.voxels.data) v = v * 200.0f;
  grey.integer_valued = false;
  grey.pixel_type = "float32";
  const std::string file = (temp_dir("grey") / "grey.nii.gz").string();
  write_image(grey, file);
  Session s;
  s.open_image(file);
  s.run_through(Stage::surface);  // submitted before the UI knows the image is grey
  settle(s);
  EXPECT_EQ(s.failed_jobs, 0u) << s.first_error;
  ASSERT_TRUE(s.edited.iso.has_value());
  EXPECT_DOUBLE_EQ(*s.edited.iso, 100.0);
  EXPECT_FALSE(s.edits_pending());  // the runs used the same default
  ASSERT_NE(s.scene()->surface_samples, nullptr);
}

// A NIfTI whose sform is 40 mm (RAS x) from its qform: one warning among the messages, the
// image placed in the sform, and read again in the qform when the panel asks for that.
TEST(Session, WarnsOfDisagreeingNiftiTransformsAndReadsTheFrameAsked) {
  const Phantom p = torus_phantom({0, 0, 0}, 9.0, 3.5);
  const std::string file = (temp_dir("frames") / "frames.nii").string();
  write_image(rasterize(p, grid_around(p, {0.8, 0.8, 1.0}, rotation_matrix({0, 0, 1}, 0))), file);
  {  // ITK writes equal transforms: move the sform's x offset (srow_x[3], at byte 292)
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    float x = 0;
    f.seekg(292);
    f.read(reinterpret_cast<char*>(&x), sizeof x);
    x += 40;
    f.seekp(292);
    f.write(reinterpret_cast<const char*>(&x), sizeof x);
  }
  Session s;
  s.open_image(file);
  s.run_through(Stage::preprocess);
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  const auto warnings = [&] {
    return std::count_if(s.messages.begin(), s.messages.end(), [](const Message& m) {
      return !m.error && m.text.rfind("warning: ", 0) == 0 && m.text.find("sform") != m.text.npos;
    });
  };
  EXPECT_EQ(warnings(), 1);
  ASSERT_EQ(s.scene()->image->frame, "sform");
  const double sform_x = s.scene()->image->grid().origin.x;

  s.edited.nifti_frame = NiftiFrame::qform;
  EXPECT_TRUE(s.edits_pending());
  s.rerun_stale();
  settle(s);
  EXPECT_EQ(s.failed_jobs, 0u) << s.first_error;
  EXPECT_EQ(s.scene()->image->frame, "qform");
  EXPECT_NEAR(s.scene()->image->grid().origin.x - sform_x, 40.0, 1e-3);  // LPS x is −RAS x
  EXPECT_FALSE(s.edits_pending());
  EXPECT_EQ(warnings(), 2);  // said again for the image read again
}

TEST(Session, StepsStageSixPassByPassWithBeforeAndAfter) {
  Session s;
  s.open_image(torus_file());
  s.run_through(Stage::shallow);
  settle(s);
  s.edited.optimize = OptimizeMode::none;  // a user who turned stage 6 off; stepping turns it back on
  // One pass: stage 5 first, optimisation turned on, the stage-5 measures kept beside.
  s.step_optimization(1);
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  EXPECT_EQ(s.edited.optimize, OptimizeMode::standard);
  const render::SceneData* scene = s.scene();
  ASSERT_NE(scene->mesh, nullptr);
  ASSERT_NE(scene->unoptimized, nullptr);
  ASSERT_NE(scene->optimization, nullptr);
  EXPECT_EQ(scene->optimization->history.size(), 2u);  // before + one pass
  EXPECT_EQ(scene->quality, nullptr);                  // evaluation stale while stepping
  const auto after_one = scene->mesh;
  const auto before = scene->unoptimized;
  const render::MeshFigures f0 = render::mesh_figures(before->measures);
  const render::MeshFigures f1 = render::mesh_figures(after_one->measures);
  // The pass statistics the core computed agree with the panel's figures of both meshes.
  EXPECT_NEAR(scene->optimization->history[0].min_dihedral_deg, f0.min_dihedral_deg, 1e-9);
  EXPECT_NEAR(scene->optimization->history[1].min_dihedral_deg, f1.min_dihedral_deg, 1e-9);
  EXPECT_GE(f1.min_dihedral_deg, f0.min_dihedral_deg);  // the worst tet never gets worse
  const bool more = s.stage_states()[int(Stage::optimize)] != StageState::done;

  // A second pass: a new mesh is drawn, the stage-5 measures are shared, not rebuilt.
  if (more) {
    s.step_optimization(1);
    settle(s);
    EXPECT_EQ(s.scene()->optimization->history.size(), 3u);
    EXPECT_NE(s.scene()->mesh, after_one);
    EXPECT_EQ(s.scene()->unoptimized, before);
  }
  // To the end, then the evaluation: every stage done, the report of the optimised mesh.
  s.step_optimization(-1);
  s.run_through(Stage::evaluate);
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  for (StageState st : s.stage_states()) EXPECT_EQ(st, StageState::done);
  ASSERT_NE(s.scene()->quality, nullptr);
  const render::MeshFigures end = render::mesh_figures(s.scene()->mesh->measures);
  for (int k = 0; k < 3; ++k)
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(end.bins_percent[k][b], s.scene()->quality->shewchuk[k].bins_percent[b], 1e-9);
  EXPECT_NEAR(end.min_dihedral_deg, s.scene()->quality->dihedral.min_deg, 1e-9);
  EXPECT_TRUE(s.scene()->quality->validity.valid);
  const int passes = int(s.scene()->optimization->history.size()) - 1;

  // An edited stage 6 option marks stage 6 pending, not stage 5; re-running starts stage 6
  // again from the kept stage-5 mesh (the same before figures) and runs it to the end.
  s.edited.optimization.max_passes = 1;
  EXPECT_EQ(s.stage_states()[int(Stage::mesh)], StageState::done);
  EXPECT_EQ(s.stage_states()[int(Stage::optimize)], StageState::pending);
  s.rerun_stale();
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  EXPECT_EQ(s.scene()->optimization->history.size(), 2u);
  EXPECT_FALSE(s.edits_pending());
  const render::MeshFigures again = render::mesh_figures(s.scene()->unoptimized->measures);
  EXPECT_EQ(again.tets, f0.tets);
  EXPECT_EQ(again.min_dihedral_deg, f0.min_dihedral_deg);
  EXPECT_GE(passes, 1);

  // Cancel while passes are queued: the rest are dropped, the mesh drawn is a valid state.
  s.edited.optimization.max_passes = 10;
  s.step_optimization(-1);
  s.cancel();
  settle(s);
  EXPECT_FALSE(s.busy());
  ASSERT_NE(s.scene()->mesh, nullptr);
  EXPECT_EQ(s.failed_jobs, 0u);
}

TEST(PipelinePanel, EditedNumbersAreKeptInTheirClosedRanges) {
  Parameters wild;
  wild.optimization.max_passes = -4;
  wild.optimization.target_dihedral_deg = 400;
  wild.margin_voxels = 0;
  wild.r = 7;  // an open end: left for validate() to refuse with its message
  clamp_to_ranges(wild);
  EXPECT_EQ(wild.optimization.max_passes, 0);
  EXPECT_EQ(wild.optimization.target_dihedral_deg, 35);
  EXPECT_EQ(wild.margin_voxels, 1);
  EXPECT_EQ(wild.r, 7);
  EXPECT_THROW(validate(wild), InputError);
}

// The user's inputs (issue 5): the command line, File > Open, drag and drop, recent files and
// the keyboard, each through the function the window calls.
TEST(Inputs, CommandLineOpensAndRuns) {
  Session s;
  start_session(s, {torus_file(), false, Stage::surface, 0});
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  EXPECT_EQ(s.image_path, torus_file());
  EXPECT_EQ(s.stage_states()[int(Stage::surface)], StageState::done);
  EXPECT_EQ(s.stage_states()[int(Stage::cvt)], StageState::stale);
  // Without an image nothing runs.
  Session empty;
  start_session(empty, {"", true, std::nullopt, 0});
  settle(empty);
  EXPECT_EQ(empty.scene(), nullptr);
  EXPECT_FALSE(empty.busy());
}

TEST(Inputs, OpenDialogListsAndOpensThePathField) {
  const auto dir = temp_dir("dialog");
  std::filesystem::create_directories(dir / "series");
  std::filesystem::create_directories(dir / ".hidden");
  for (const char* name : {"b.nii.gz", "A.NRRD", "notes.txt", ".secret.nii"})
    std::ofstream(dir / name) << "x";
  const FolderListing listing = list_folder(dir.string(), image_extensions());
  EXPECT_TRUE(listing.error.empty());
  ASSERT_EQ(listing.folders.size(), 1u);
  EXPECT_EQ(listing.folders[0], (dir / "series").string());
  ASSERT_EQ(listing.files.size(), 2u);  // images only, case-insensitive, sorted, no hidden
  EXPECT_EQ(listing.files[0], (dir / "A.NRRD").string());
  EXPECT_EQ(listing.files[1], (dir / "b.nii.gz").string());
  EXPECT_EQ(list_folder(dir.string(), {}).files.size(), 3u);
  EXPECT_FALSE(list_folder((dir / "missing").string(), {}).error.empty());

  // Ctrl+O opens the dialog on the working folder; the path field is what opens.
  Session s;
  ViewSettings view;
  UiState ui;
  perform(*action_for_key(GLFW_KEY_O, true, false), s, view, ui);
  EXPECT_TRUE(ui.open_image.open);
  EXPECT_EQ(ui.open_image.folder, std::filesystem::current_path().string());
  ui.open_image.path = "";
  confirm_dialog(Dialog::open_image, s, ui);  // an empty path does nothing
  EXPECT_TRUE(ui.open_image.open);
  ui.open_image.path = torus_file();
  confirm_dialog(Dialog::open_image, s, ui);
  EXPECT_FALSE(ui.open_image.open);
  settle(s);
  EXPECT_EQ(s.image_path, torus_file());
  ASSERT_NE(s.scene(), nullptr);
  EXPECT_NE(s.scene()->image, nullptr);
  // A bad path from the field: an error message, the image stays.
  open_dialog(ui.open_image, "");
  ui.open_image.path = (dir / "notes.txt").string();
  confirm_dialog(Dialog::open_image, s, ui);
  settle(s);
  EXPECT_TRUE(s.messages.back().error);
  EXPECT_EQ(s.image_path, torus_file());
}

TEST(Inputs, DroppedFilesAndRecentFiles) {
  const std::string recent = (temp_dir("recent_session") / "recent.txt").string();
  std::filesystem::remove(recent);
  {
    SessionOptions options;
    options.recent_files_path = recent;
    Session s(options);
    std::vector<std::string> dropped{torus_file(), "/nonexistent/second.nii"};
    open_dropped(s, dropped);
    EXPECT_TRUE(dropped.empty());
    settle(s);
    EXPECT_EQ(s.failed_jobs, 0u);  // only the first is opened
    EXPECT_EQ(s.image_path, torus_file());
    ASSERT_FALSE(s.recent().files().empty());
    EXPECT_EQ(s.recent().files().front(), torus_file());
    bool named = false;
    for (const Message& m : s.messages) named |= m.text.find("2 files dropped") != std::string::npos;
    EXPECT_TRUE(named);
    // A failed open does not enter the list.
    std::vector<std::string> bad{"/nonexistent/liver.nii.gz"};
    open_dropped(s, bad);
    settle(s);
    EXPECT_EQ(s.recent().files().size(), 1u);
  }
  // The next session finds it, and opening the entry (File > Recent) opens the image.
  SessionOptions options;
  options.recent_files_path = recent;
  Session next(options);
  ASSERT_EQ(next.recent().files().size(), 1u);
  next.open_image(next.recent().files().front());
  settle(next);
  EXPECT_EQ(next.failed_jobs, 0u);
  EXPECT_NE(next.scene()->image, nullptr);
}

TEST(Inputs, KeyBindingsMatchTheHelpAndDoWhatItSays) {
  // One binding per key and modifiers; the help lists each binding with its label.
  const auto& bindings = key_bindings();
  const auto help = help_lines();
  for (std::size_t i = 0; i < bindings.size(); ++i) {
    const KeyBinding& b = bindings[i];
    for (std::size_t j = i + 1; j < bindings.size(); ++j)
      EXPECT_FALSE(b.key == bindings[j].key && b.ctrl == bindings[j].ctrl &&
                   b.shift == bindings[j].shift)
          << key_label(b) << " bound twice";
    EXPECT_EQ(action_for_key(b.key, b.ctrl, b.shift), b.action);
    ASSERT_LT(i, help.size());
    EXPECT_EQ(help[i].keys, key_label(b));
    EXPECT_EQ(help[i].action, action_description(b.action));
    // Scripted presses name keys as the help does.
    int key;
    bool ctrl, shift;
    ASSERT_TRUE(parse_key_chord(key_label(b), key, ctrl, shift)) << key_label(b);
    EXPECT_EQ(key, b.key);
    EXPECT_EQ(ctrl, b.ctrl);
    EXPECT_EQ(shift, b.shift);
  }
  EXPECT_FALSE(action_for_key(GLFW_KEY_O, true, true).has_value());  // exact modifiers
  int key;
  bool ctrl, shift;
  EXPECT_FALSE(parse_key_chord("ctrl+%", key, ctrl, shift));
  EXPECT_EQ(key_label({GLFW_KEY_L, false, true, Action::lloyd_10}), "Shift+L");
  EXPECT_EQ(key_label({GLFW_KEY_F12, false, false, Action::screenshot}), "F12");

  // The keys act on the session and the view as described.
  Session s;
  ViewSettings view;
  UiState ui;
  auto press = [&](int k, bool c = false, bool sh = false) {
    const auto a = action_for_key(k, c, sh);
    ASSERT_TRUE(a.has_value()) << k;
    perform(*a, s, view, ui);
  };
  press(GLFW_KEY_R, true);  // no image yet: nothing runs
  EXPECT_FALSE(s.busy());
  press(GLFW_KEY_E, true);  // no mesh: no export dialog
  EXPECT_FALSE(ui.export_mesh.open);
  s.open_image(torus_file());
  settle(s);
  press(GLFW_KEY_N);  // the next stage
  settle(s);
  EXPECT_EQ(s.stage_states()[int(Stage::preprocess)], StageState::done);
  EXPECT_EQ(s.stage_states()[int(Stage::surface)], StageState::stale);
  press(GLFW_KEY_L);  // one Lloyd iteration
  settle(s);
  ASSERT_NE(s.lloyd(), nullptr);
  EXPECT_EQ(s.lloyd()->history.size(), 1u);
  press(GLFW_KEY_L, false, true);  // ten more (or fewer, up to convergence)
  settle(s);
  EXPECT_GT(s.lloyd()->history.size(), 1u);
  EXPECT_TRUE(s.lloyd()->history.size() == 11u || s.lloyd()->converged);
  press(GLFW_KEY_O);  // one optimisation pass (stage 5 first)
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  ASSERT_NE(s.scene()->optimization, nullptr);
  EXPECT_EQ(s.scene()->optimization->history.size(), 2u);
  press(GLFW_KEY_R, true);  // run all
  settle(s);
  for (StageState st : s.stage_states()) EXPECT_EQ(st, StageState::done);
  press(GLFW_KEY_E, true);
  EXPECT_TRUE(ui.export_mesh.open);
  EXPECT_EQ(ui.export_mesh.path, "mesh.vtu");

  const ViewMode mode = view.mode;
  press(GLFW_KEY_TAB);
  EXPECT_NE(view.mode, mode);
  press(GLFW_KEY_TAB), press(GLFW_KEY_TAB);
  EXPECT_EQ(view.mode, mode);
  press(GLFW_KEY_1);
  EXPECT_EQ(view.slice_axis, 0);
  const int middle = effective_slice_index(view, *s.scene());
  press(GLFW_KEY_UP);
  EXPECT_EQ(view.slice_index, middle + 1);
  press(GLFW_KEY_PAGE_DOWN);
  EXPECT_EQ(view.slice_index, middle - 9);
  press(GLFW_KEY_3);
  EXPECT_EQ(view.slice_axis, 2);
  EXPECT_EQ(view.slice_index, -1);
  const bool clip = view.clip_enabled;
  press(GLFW_KEY_C);
  EXPECT_NE(view.clip_enabled, clip);
  press(GLFW_KEY_C, false, true);
  EXPECT_TRUE(view.clip_flip);
  press(GLFW_KEY_F1);
  EXPECT_TRUE(ui.show_help);
  press(GLFW_KEY_H);
  EXPECT_FALSE(ui.show_help);
  press(GLFW_KEY_F2);
  EXPECT_FALSE(ui.show_pipeline || ui.show_quality || ui.show_view);
  press(GLFW_KEY_F);
  EXPECT_TRUE(ui.fit_3d && ui.fit_slice);
  press(GLFW_KEY_F12);
  EXPECT_TRUE(ui.screenshot.open);
  ui.screenshot.path = "shot.png";
  ui.screenshot_scale = 3;
  confirm_dialog(Dialog::screenshot, s, ui);
  ASSERT_TRUE(ui.screenshot_request.has_value());
  EXPECT_EQ(ui.screenshot_request->scale, 3);
  // Esc cancels a running job and the queue behind it.
  press(GLFW_KEY_O, false, true);  // stage 6 is done: the pass jobs do nothing
  s.step_lloyd(50);
  press(GLFW_KEY_ESCAPE);
  settle(s);
  EXPECT_FALSE(s.busy());
  press(GLFW_KEY_Q, true);
  EXPECT_TRUE(ui.quit);
}

TEST(Session, CancelStopsLloydWithinASecondAndKeepsTheStateBefore) {
  Session s;
  s.edited.epsilon_mm = 1e-12;  // never converges: only the cancel ends the run below
  s.edited.max_iterations = 100000;
  s.open_image(torus_file());
  s.run_through(Stage::surface);
  s.step_lloyd(2);
  settle(s);
  ASSERT_EQ(s.failed_jobs, 0u) << s.first_error;
  const auto surface = s.scene()->surface_samples;
  ASSERT_NE(surface, nullptr);
  const std::size_t sites = s.lloyd()->sites_world.size();

  s.step_lloyd(-1);
  // Cancel while it iterates (a live state past the two earlier iterations has been posted).
  while (!s.lloyd() || s.lloyd()->history.size() < 5) {
    s.poll(0);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const auto t0 = std::chrono::steady_clock::now();
  s.cancel();
  s.wait_idle();
  const std::chrono::duration<double> took = std::chrono::steady_clock::now() - t0;
  EXPECT_LT(took.count(), 1.0);
  s.poll(0);
  EXPECT_EQ(s.failed_jobs, 0u);
  // The cancel is reported — unless the discrete Lloyd iteration reached an exact fixed point
  // (Σ displacement 0 < ε) before the cancel arrived, which a fast machine can do on the torus.
  const bool cancelled = std::any_of(s.messages.begin(), s.messages.end(), [](const auto& m) {
    return m.text.find("cancelled") != std::string::npos;
  });
  ASSERT_NE(s.lloyd(), nullptr);
  EXPECT_TRUE(cancelled || s.lloyd()->converged);
  // Earlier stages untouched; the sites are those of the last whole iteration, still usable.
  ASSERT_NE(s.scene(), nullptr);
  EXPECT_EQ(s.scene()->surface_samples, surface);
  ASSERT_NE(s.lloyd(), nullptr);
  EXPECT_GE(s.lloyd()->history.size(), 5u);
  EXPECT_EQ(s.lloyd()->sites_world.size(), sites);
  EXPECT_EQ(s.stage_states()[int(Stage::surface)], StageState::done);
  // And the next run carries on from there.
  s.step_lloyd(1);
  settle(s);
  EXPECT_EQ(s.failed_jobs, 0u) << s.first_error;
}

TEST(Session, ABadPresetLeavesTheParametersAsTheyWere) {
  Session s;
  s.edited.r = 0.33;
  s.edited.seed = 7;
  const Parameters before = s.edited;
  const auto dir = temp_dir("bad_presets");
  const std::pair<const char*, const char*> cases[] = {
      {R"({"r": -0.5})", "r"},
      {R"({"sigma_surface_mm": 0})", "sigma_surface_mm"},
      {R"({"epsilon_mm": -1})", "epsilon_mm"},
      {R"({"r": 0.2, "max_iterations": -5})", "max_iterations"},  // the valid r is not taken
      {R"({"seed": "x"})", "seed"},
      {R"({"radius": 1})", "radius"},
      {R"({"r": 0.2,)", "JSON"},
  };
  int i = 0;
  for (const auto& [text, key] : cases) {
    const std::string path = (dir / ("p" + std::to_string(i++) + ".json")).string();
    std::ofstream(path) << text;
    EXPECT_FALSE(s.load_preset(path)) << text;
    EXPECT_EQ(s.edited, before) << text;
    ASSERT_FALSE(s.messages.empty());
    EXPECT_TRUE(s.messages.back().error);
    EXPECT_NE(s.messages.back().text.find(path), std::string::npos) << s.messages.back().text;
    EXPECT_NE(s.messages.back().text.find(key), std::string::npos) << s.messages.back().text;
    EXPECT_EQ(s.messages.back().text.find('\n'), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

TEST(PipelineWorker, RunsTenNiceLevelsBelowTheThreadThatMadeIt) {
  const auto nice_of_this_thread = [] {
    errno = 0;
    const int n = getpriority(PRIO_PROCESS, pid_t(syscall(SYS_gettid)));
    return errno ? 0 : n;
  };
  const int ui = nice_of_this_thread();
  PipelineWorker worker(1);
  std::atomic<int> job_nice{-100};
  worker.submit("nice", [&](JobContext&) { job_nice = nice_of_this_thread(); });
  worker.wait_idle();
  EXPECT_EQ(job_nice.load(), std::min(ui + 10, 19));
}
