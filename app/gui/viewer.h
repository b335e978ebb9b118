// The cvtmesh-gui window: GLFW + Dear ImGui over the Session (worker) and the SceneRenderer.
// Interactive by default; scripted runs (open, run, screenshot, benchmark, exit) use the same
// loop, so a screenshot shows exactly what a user would see.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ui.h"
#include "view_settings.h"

namespace cvt::gui {

struct ViewerOptions {
  std::string image;                            // opened at start (empty: none)
  std::string preset;                           // loaded at start
  bool run_all = false;                         // run every stage at start
  std::optional<Stage> run_through;             // or the stages up to this one
  // Stage 6 passes stepped at start, one job each (< 0: to the end; 0: none). With run_all:
  // stages 1-4 first, then the passes, then what is left (the rest of stage 6, evaluation).
  int optimize_passes = 0;
  std::optional<ScreenshotRequest> screenshot;  // taken once every job is done
  bool exit_when_done = false;                  // quit after the jobs (and screenshot)
  int benchmark_frames = 0;                     // time this many frames once done, print stats
  bool panels = false;                          // draw the panels in scripted runs too
  int width = 1280, height = 800;               // window size (screen units)
  ViewSettings view;                            // initial view
  int max_threads = 0;                          // worker TBB threads (0 = all cores)
  std::vector<std::string> show_windows;        // windows/dialogs open at start (show_window)
  std::vector<std::string> drop;   // paths dropped on the window at start (scripted)
  std::vector<std::string> press;  // key chords pressed once each job is done (scripted)
};

// Runs the window until it is closed (or the scripted run ends). Returns the exit code: 0, or 1
// with one line on stderr when a file, a stage or the screenshot failed in a scripted run.
int run_viewer(const ViewerOptions& options);

}  // namespace cvt::gui
