#include "viewer.h"

#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include "gl.h"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <vector>

#include "frame_stats.h"
#include "input_actions.h"
#include "screenshot.h"
#include "view_cache.h"

namespace cvt::gui {
namespace {

double now_s() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

// What GLFW reports between frames, behind the window's user pointer (its callbacks run during
// event polling, on the UI thread): paths dropped on the window, which the loop opens, and
// whether the user did anything (ImGui's own callbacks chain to these).
struct WindowEvents {
  std::vector<std::string> dropped;
  bool input = false;
};

WindowEvents& events_of(GLFWwindow* window) {
  return *static_cast<WindowEvents*>(glfwGetWindowUserPointer(window));
}

void on_drop(GLFWwindow* window, int count, const char** paths) {
  for (int i = 0; i < count; ++i) events_of(window).dropped.emplace_back(paths[i]);
  events_of(window).input = true;
}

void watch_input(GLFWwindow* window) {
  glfwSetDropCallback(window, on_drop);
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double, double) { events_of(w).input = true; });
  glfwSetMouseButtonCallback(window,
                             [](GLFWwindow* w, int, int, int) { events_of(w).input = true; });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double) { events_of(w).input = true; });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int, int, int, int) { events_of(w).input = true; });
  glfwSetCharCallback(window, [](GLFWwindow* w, unsigned) { events_of(w).input = true; });
  glfwSetWindowSizeCallback(window, [](GLFWwindow* w, int, int) { events_of(w).input = true; });
  glfwSetWindowFocusCallback(window, [](GLFWwindow* w, int) { events_of(w).input = true; });
}

// While a job runs, a frame (progress, the latest Lloyd state) comes at most this often unless
// the user acts or a job ends: on a software renderer every frame takes CPU from the pipeline.
constexpr double kBusyFrameInterval_s = 0.5;

// Waits for the next frame while a job runs: an input event, a finished job, or the interval.
void wait_while_busy(GLFWwindow* window, const Session& session, double last_draw_s) {
  WindowEvents& events = events_of(window);
  events.input = false;
  glfwPollEvents();
  const double due = last_draw_s + kBusyFrameInterval_s;
  for (double now = now_s(); !events.input && !session.has_finished_job() && now < due;
       now = now_s())
    glfwWaitEventsTimeout(due - now);
}

// Mouse on the views (when ImGui does not want it): orbit/pan/zoom in 3D; pan, zoom, slice and
// window/level on the slice.
class MouseControl {
 public:
  void update(UiContext& ctx, const ViewRects& rects) {
    const ImGuiIO& io = ImGui::GetIO();
    const ImVec2 m = io.MousePos;
    const bool any_down = io.MouseDown[0] || io.MouseDown[1] || io.MouseDown[2];
    if (!any_down) target_ = 0;
    if (io.WantCaptureMouse && target_ == 0) return;
    const bool in3d = rects.view3d.contains(m.x, m.y), in_slice = rects.slice.contains(m.x, m.y);
    if (target_ == 0 && any_down &&
        (io.MouseClicked[0] || io.MouseClicked[1] || io.MouseClicked[2]))
      target_ = in3d ? 1 : in_slice ? 2 : 0;
    const ImVec2 d = io.MouseDelta;
    SceneRenderer& r = ctx.renderer;
    ViewSettings& v = ctx.view;
    if (target_ == 1) {
      if ((io.MouseDown[0] && io.KeyShift) || io.MouseDown[1] || io.MouseDown[2])
        r.camera.pan(d.x, d.y, rects.view3d.h);
      else if (io.MouseDown[0])
        r.camera.orbit(d.x, d.y);
    } else if (target_ == 2) {
      if (io.MouseDown[0]) r.slice_transform.pan(d.x, d.y);
      if (io.MouseDown[1] && ctx.session.scene()) {
        const render::SceneData& s = *ctx.session.scene();
        render::WindowLevel wl =
            v.window_level.value_or(render::default_window_level(s.value_range));
        const double range = std::max(s.value_range.max - s.value_range.min, 1e-6);
        wl.window = std::max(1e-6, wl.window + d.x * range / 400.0);
        wl.level += d.y * range / 400.0;
        v.window_level = wl;
      }
    }
    if (io.MouseWheel != 0 && target_ == 0 && !io.WantCaptureMouse) {
      if (in3d) r.camera.zoom(io.MouseWheel);
      if (in_slice && io.KeyCtrl && ctx.session.scene() && ctx.session.scene()->image) {
        const int n = ctx.session.scene()->image->grid().dims[v.slice_axis];
        v.slice_index = std::clamp(
            effective_slice_index(v, *ctx.session.scene()) + int(std::lround(io.MouseWheel)), 0,
            n - 1);
      } else if (in_slice) {
        r.slice_transform.zoom_at(io.MouseWheel, m.x - rects.slice.x, m.y - rects.slice.y,
                                  rects.slice.w, rects.slice.h);
      }
    }
  }

 private:
  int target_ = 0;  // the view a drag started in: 0 none, 1 3D, 2 slice
};

// Scripted key presses go in as GLFW key events through the callback ImGui's GLFW backend
// installed, the path a real key takes: the chord is pressed in one frame, released in the next.
class ScriptedKeys {
 public:
  explicit ScriptedKeys(const std::vector<std::string>& chords) {
    for (const std::string& c : chords) {
      Chord k;
      if (parse_key_chord(c, k.key, k.ctrl, k.shift)) chords_.push_back(k);
    }
  }
  bool pending() const { return next_ < chords_.size() || down_; }
  // Call once per frame before ImGui's new frame, when the previous action has finished.
  void feed(GLFWwindow* window, bool ready) {
    if (down_) {
      release(window, held_);
      down_ = false;
      return;
    }
    if (!ready || next_ >= chords_.size()) return;
    const Chord& k = chords_[next_++];
    if (k.ctrl) ImGui_ImplGlfw_KeyCallback(window, GLFW_KEY_LEFT_CONTROL, 0, GLFW_PRESS, 0);
    if (k.shift) ImGui_ImplGlfw_KeyCallback(window, GLFW_KEY_LEFT_SHIFT, 0, GLFW_PRESS, 0);
    const int mods = (k.ctrl ? GLFW_MOD_CONTROL : 0) | (k.shift ? GLFW_MOD_SHIFT : 0);
    ImGui_ImplGlfw_KeyCallback(window, k.key, 0, GLFW_PRESS, mods);
    held_ = k;
    down_ = true;
  }

 private:
  struct Chord {
    int key = 0;
    bool ctrl = false, shift = false;
  };
  static void release(GLFWwindow* window, const Chord& k) {
    ImGui_ImplGlfw_KeyCallback(window, k.key, 0, GLFW_RELEASE, 0);
    if (k.shift) ImGui_ImplGlfw_KeyCallback(window, GLFW_KEY_LEFT_SHIFT, 0, GLFW_RELEASE, 0);
    if (k.ctrl) ImGui_ImplGlfw_KeyCallback(window, GLFW_KEY_LEFT_CONTROL, 0, GLFW_RELEASE, 0);
  }
  std::vector<Chord> chords_;
  std::size_t next_ = 0;
  Chord held_;  // pressed in the last frame, while down_
  bool down_ = false;
};

struct GlfwScope {
  GlfwScope() : ok(glfwInit() == GLFW_TRUE) {}
  ~GlfwScope() {
    if (ok) glfwTerminate();
  }
  bool ok;
};

}  // namespace

int run_viewer(const ViewerOptions& options) {
  glfwSetErrorCallback([](int code, const char* text) {
    std::fprintf(stderr, "cvtmesh-gui: GLFW error %d: %s\n", code, text);
  });
  GlfwScope glfw;
  if (!glfw.ok) {
    std::fprintf(stderr,
                 "cvtmesh-gui: cannot initialise GLFW (is there a display? try xvfb-run)\n");
    return 1;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  GLFWwindow* window =
      glfwCreateWindow(options.width, options.height, "cvtmesh-gui", nullptr, nullptr);
  if (!window) {
    std::fprintf(stderr, "cvtmesh-gui: cannot create an OpenGL 3.3 core window\n");
    return 1;
  }
  glfwMakeContextCurrent(window);
  const bool scripted = options.exit_when_done;
  glfwSwapInterval(scripted ? 0 : 1);
  WindowEvents events;
  glfwSetWindowUserPointer(window, &events);
  watch_input(window);  // before ImGui's callbacks, which chain to these

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  // Window placement of the dialogs, next to the recent files (not for scripted runs).
  std::string ini_path = default_recent_files_path();
  if (!ini_path.empty() && !scripted)
    ini_path = (std::filesystem::path(ini_path).parent_path() / "imgui.ini").string();
  else
    ini_path.clear();
  io.IniFilename = ini_path.empty() ? nullptr : ini_path.c_str();
  ImGui::StyleColorsDark();
  // DejaVu Sans (Debian's fonts-dejavu-core) has the Greek letters and symbols of the
  // parameter names and tooltips (σ, λ, θ, ε, ρ, ≥, Σ); ImGui's built-in font shows '?'.
  static const ImWchar glyphs[] = {0x0020, 0x00FF, 0x0370, 0x03FF, 0x2000,
                                   0x206F, 0x2190, 0x22FF, 0};
  const char* font = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  if (std::filesystem::exists(font)) io.Fonts->AddFontFromFileTTF(font, 15.0f, nullptr, glyphs);
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  int exit_code = 0;
  {
    SessionOptions session_options;
    session_options.max_threads = options.max_threads;
    if (!scripted) session_options.recent_files_path = default_recent_files_path();
    Session session(session_options);
    session.set_notify([] { glfwPostEmptyEvent(); });  // wakes a paced frame for a finished job
    ViewSettings view = options.view;
    UiState ui;
    std::unique_ptr<SceneRenderer> renderer;
    try {
      renderer = std::make_unique<SceneRenderer>();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "cvtmesh-gui: %s\n", e.what());
      exit_code = 1;
    }
    render::Framebuffer screenshot_fbo;
    ViewCache view_cache;
    MouseControl mouse;
    if (!options.preset.empty() && !session.load_preset(options.preset) && scripted) {
      std::fprintf(stderr, "cvtmesh-gui: %s\n", session.messages.back().text.c_str());
      exit_code = 1;
    }
    start_session(session, {options.image, options.run_all, options.run_through,
                            options.optimize_passes});
    // Scripted drops go through the drop callback GLFW calls.
    if (!options.drop.empty()) {
      std::vector<const char*> paths;
      for (const std::string& p : options.drop) paths.push_back(p.c_str());
      on_drop(window, int(paths.size()), paths.data());
    }
    ScriptedKeys keys(options.press);

    for (const std::string& name : options.show_windows) show_window(ui, name);
    std::optional<ScreenshotRequest> scripted_shot = options.screenshot;
    int ready_frames = 0, idle_frames = 0;
    BenchmarkRecorder bench(options.benchmark_frames);
    Rect last_area;
    double last_draw_s = 0;  // when the last frame began its work
    while (renderer && exit_code == 0 && !glfwWindowShouldClose(window) && !ui.quit) {
      const double frame_start = now_s();
      const double cpu_start = options.benchmark_frames ? render_cpu_ms() : 0.0;
      const bool was_idle = !session.busy();
      const std::string running_job = session.worker_status().job;
      // While a job runs, frames are paced (wait_while_busy), so the lower-priority pipeline
      // threads keep the cores. Idle, benchmarks draw continuously, scripted runs (which have
      // no events) every 1/30 s, and others wait for events.
      if (session.busy())
        wait_while_busy(window, session, last_draw_s);
      else if (options.benchmark_frames)
        glfwPollEvents();
      else
        glfwWaitEventsTimeout(scripted ? 1.0 / 30 : 0.5);
      const double work_start = now_s();
      last_draw_s = work_start;
      open_dropped(session, events.dropped);
      session.poll(now_s());
      keys.feed(window, idle_frames >= 2);
      if (scripted && session.failed_jobs > 0) {
        std::fprintf(stderr, "cvtmesh-gui: %s\n", session.first_error.c_str());
        exit_code = 1;
        break;
      }

      int win_w = 0, win_h = 0, fb_w = 0, fb_h = 0;
      glfwGetWindowSize(window, &win_w, &win_h);
      glfwGetFramebufferSize(window, &fb_w, &fb_h);
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      // The panels are pinned beside the views; scripted runs show the views alone.
      const bool show_ui = !scripted || options.panels ||
                           (options.screenshot && options.screenshot->include_ui);
      const float bar = show_ui ? ImGui::GetFrameHeight() : 0.0f;
      const float status = show_ui ? ImGui::GetFrameHeight() + 8 : 0.0f;
      layout_panels(ui, float(win_w), float(win_h), bar, status);
      const Rect area = views_area(
          float(win_w), float(win_h), show_ui && ui.show_pipeline ? kLeftPanelWidth : 0.0f,
          show_ui && (ui.show_quality || ui.show_view) ? kRightPanelWidth : 0.0f, bar, status);
      const ViewRects rects = view_rects(view.mode, area);
      if (area.w != last_area.w || area.h != last_area.h) ui.fit_slice = last_area.w > 0;
      last_area = area;
      ui.now_s = now_s();
      UiContext ctx{session, view, *renderer, ui};
      mouse.update(ctx, rects);
      handle_shortcuts(ctx);
      if (show_ui) {
        draw_menu_bar(ctx);
        draw_pipeline_panel(ctx);
        draw_quality_panel(ctx);
        draw_view_panel(ctx);
        draw_file_dialogs(ctx);
        draw_help_window(ctx);
        draw_messages_window(ctx);
        draw_status_bar(ctx);
      }
      draw_legends(ctx, rects);
      ImGui::Render();

      const double sync_start = now_s();
      renderer->sync(session.scene_ptr(), session.lloyd(), view, rects);
      const double sync_ms = 1000.0 * (now_s() - sync_start);
      if (ui.fit_3d) renderer->fit_3d(), ui.fit_3d = false;
      if (ui.fit_slice) renderer->fit_slice(rects.slice), ui.fit_slice = false;
      // While a job runs and the user does nothing, the views' picture is kept (view_cache.h).
      view_cache.draw(*renderer, session.scene_ptr(), session.lloyd(), view, rects,
                      {fb_w, fb_h, float(fb_w) / float(std::max(win_w, 1))},
                      session.busy() && !events.input);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());

      if (ui.screenshot_request) {
        try {
          take_screenshot(*ui.screenshot_request, *renderer, view, area, win_w, win_h,
                          screenshot_fbo);
          session.messages.push_back({false, "saved " + ui.screenshot_request->path});
        } catch (const std::exception& e) {
          session.messages.push_back({true, e.what()});
        }
        ui.screenshot_request.reset();
      }
      // Scripted: once every job is done and the legends had two frames to size themselves.
      const bool idle = was_idle && !session.busy() && !renderer->busy();
      idle_frames = idle ? idle_frames + 1 : 0;
      const bool done = idle && !keys.pending();
      if (done)
        ++ready_frames;
      else
        ready_frames = 0;
      if (scripted_shot && ready_frames == 3) {
        try {
          take_screenshot(*scripted_shot, *renderer, view, area, win_w, win_h, screenshot_fbo);
        } catch (const std::exception& e) {
          std::fprintf(stderr, "cvtmesh-gui: %s\n", e.what());
          exit_code = 1;
        }
        scripted_shot.reset();
      }
      glfwSwapBuffers(window);
      if (options.benchmark_frames) glFinish();  // time the whole frame, not just its submission

      // A paced frame's wait is not its time: from the start of its work.
      const double frame_ms = 1000.0 * (now_s() - (session.busy() || !was_idle ? work_start : frame_start));
      ui.frame_ms = 1000.0 * (now_s() - work_start);
      if (options.benchmark_frames) {
        if (frame_ms > 50 && std::getenv("CVTMESH_GUI_TRACE"))
          std::fprintf(stderr, "slow frame %.1f ms (sync %.1f ms) during '%s'\n", frame_ms, sync_ms,
                       running_job.c_str());
        const double cpu_end = render_cpu_ms();
        bench.record(frame_ms, was_idle ? "" : running_job, ready_frames > 3,
                     cpu_start >= 0 && cpu_end >= 0 ? cpu_end - cpu_start : -1.0);
        if (const double x = bench.sweep_position(); x >= 0)
          view.clip_enabled = true, view.clip_position = x;
        if (bench.done()) break;
      } else if (scripted && ready_frames > 3 && !scripted_shot) {
        break;
      }
    }
    // Scripted runs that optimised say what stage 6 did (the quality panel's figures).
    if (scripted && exit_code == 0 && session.scene() && session.scene()->unoptimized &&
        session.scene()->mesh && session.scene()->optimization) {
      const render::SceneData& sc = *session.scene();
      const render::MeshFigures before = render::mesh_figures(sc.unoptimized->measures);
      const render::MeshFigures after = render::mesh_figures(sc.mesh->measures);
      std::printf(
          "stage 6: %d passes, tets %zu -> %zu, min dihedral %.2f -> %.2f deg, tets below 10 "
          "deg %zu -> %zu\n",
          int(sc.optimization->history.size()) - 1, before.tets, after.tets,
          before.min_dihedral_deg, after.min_dihedral_deg, before.below_10, after.below_10);
    }
    if (scripted && exit_code == 0)
      std::printf("views: %llu frames drawn, %llu re-shown while jobs ran\n",
                  (unsigned long long)view_cache.drawn, (unsigned long long)view_cache.reshown);
    if (options.benchmark_frames) {
      std::printf("window %dx%d, %s\n", options.width, options.height,
                  reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
      if (session.scene() && session.scene()->mesh)
        std::printf("mesh: %zu tets; drawn at the end: %zu kept tets, %zu cut faces\n",
                    session.scene()->mesh->mesh.tets.size(), renderer->kept_tets,
                    renderer->cut_faces);
      for (const Session::JobTime& j : session.job_times)
        std::printf("job %-22s %6.2f s (snapshot for the views %.2f s)\n", j.name.c_str(), j.wall_s,
                    j.snapshot_s);
      std::printf("%s", bench.report().c_str());
    }
    session.cancel();
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  return exit_code;
}

}  // namespace cvt::gui
