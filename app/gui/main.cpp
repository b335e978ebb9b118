// cvtmesh-gui: the interactive viewer, or a scripted renderer of any state:
//   cvtmesh-gui IMAGE --run-all --view 3d --clip 0.5 --screenshot cut.png --exit
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "base/huge_page_malloc.h"
#include "input_actions.h"
#include "viewer.h"

namespace {

// "1280x800" → width, height.
bool parse_size(const std::string& text, int& w, int& h) {
  return std::sscanf(text.c_str(), "%dx%d", &w, &h) == 2 && w >= 64 && h >= 64 && w <= 8192 &&
         h <= 8192;
}

}  // namespace

int main(int argc, char** argv) {
  cvt::reexec_with_huge_page_malloc(argv);
  using namespace cvt::gui;
  CLI::App app{"cvtmesh-gui: view and drive the cvtmesh pipeline (interactive or scripted)"};
  ViewerOptions o;
  std::string screenshot, view_mode = "split", colour_by, window_size = "1280x800";
  std::vector<std::string> overlays;
  int scale = 1;
  bool transparent = false;
  double clip = -1;
  app.add_option("IMAGE", o.image, "Image file or DICOM/slice folder to open");
  app.add_option("--preset", o.preset, "Load parameters from this JSON preset");
  app.add_flag("--run-all", o.run_all, "Run every stage after opening the image");
  std::string run_through;
  std::vector<std::string> stage_keys;
  for (int s = 0; s < cvt::kStageCount; ++s)
    stage_keys.emplace_back(cvt::stage_key(cvt::Stage(s)));
  std::string stage_list;
  for (const std::string& k : stage_keys) stage_list += (stage_list.empty() ? "" : ", ") + k;
  app.add_option("--run-through", run_through, "Run the stages up to this one: " + stage_list)
      ->check(CLI::IsMember(stage_keys));
  app.add_option("--optimize-passes", o.optimize_passes,
                 "Step stage 6 this many passes at start, one job each (-1: to the end); turns "
                 "optimisation on. With --run-all: stages 1-4, the passes, then the rest")
      ->check(CLI::Range(-1, 100));
  app.add_option("--screenshot", screenshot, "Save a PNG of the views once every job is done");
  app.add_option("--scale", scale, "Screenshot size as a multiple of the window size (1-4)")
      ->check(CLI::Range(1, 4));
  app.add_flag("--transparent", transparent, "Screenshot with a transparent background");
  bool include_ui = false;
  app.add_flag("--screenshot-ui", include_ui, "Screenshot the whole window, panels included");
  app.add_flag("--panels", o.panels,
               "Draw the panels in a scripted run too (benchmarks of what a user sees)");
  app.add_option("--view", view_mode, "Views: 3d, slice or split (both side by side)")
      ->check(CLI::IsMember({"3d", "slice", "split"}));
  app.add_option("--slice-axis", o.view.slice_axis, "Slice axis: 0 sagittal, 1 coronal, 2 axial")
      ->check(CLI::Range(0, 2));
  app.add_option("--slice-index", o.view.slice_index,
                 "Slice index in image voxels (default: the middle of the object)");
  app.add_option("--overlay", overlays,
                 "Overlays to show instead of the default ones: object lfs medial samples "
                 "interior shallow poles voronoi (or none)")
      ->expected(1, -1)
      ->delimiter(',');
  app.add_option("--clip", clip,
                 "Remove the whole tets below this fraction (0-1) of the mesh box along the "
                 "clip axis (the side facing the default camera for axis 1)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--clip-axis", o.view.clip_axis, "Clip plane normal: world axis 0, 1 or 2")
      ->check(CLI::Range(0, 2));
  app.add_flag("--clip-flip", o.view.clip_flip, "Remove the tets above the plane instead");
  app.add_option("--colour-by,--color-by", colour_by,
                 "Colour of the cut faces: none, v_over_rmc3, gradient_error, condition_number, "
                 "min_dihedral_deg, max_dihedral_deg, radius_edge");
  app.add_flag("--colour-boundary,--color-boundary", o.view.color_boundary,
               "Colour the boundary faces by the measure too");
  std::string highlight;
  app.add_option("--highlight", highlight,
                 "Highlight the tets of a Table I bin, as a click in the quality panel does: "
                 "MEASURE:BIN with BIN 0 (low), 1 (middle) or 2 (high), e.g. v_over_rmc3:0");
  app.add_option("--point-size", o.view.point_size_px, "Point sprite size in pixels")
      ->check(CLI::Range(1.0, 32.0));
  app.add_flag("--slice-plane", o.view.show_slice_plane, "Show the slice as a plane in 3D");
  app.add_option("--window", window_size, "Window size WxH in screen units");
  app.add_option("--show-window", o.show_windows,
                 "Open a window or dialog at start: help, messages, open, export, load-preset, "
                 "save-preset, screenshot (with --screenshot-ui, to picture the interface)")
      ->check(CLI::IsMember(
          {"help", "messages", "open", "export", "load-preset", "save-preset", "screenshot"}));
  app.add_option("--drop", o.drop,
                 "Drop these paths on the window at start, through GLFW's drop callback (tests)");
  app.add_option("--press", o.press,
                 "Press these keys one after the other, each once every job is done, as GLFW "
                 "key events (tests), e.g. ctrl+r shift+o f1; see the help window for the keys")
      ->expected(1, -1);
  app.add_option("--threads", o.max_threads, "Threads for the pipeline (0 = all cores)");
  app.add_flag("--exit", o.exit_when_done, "Quit once every job is done (scripted mode)");
  app.add_option("--benchmark-frames", o.benchmark_frames,
                 "Once done, time this many frames of the view as set, then as many with the "
                 "clip plane moving; print frame-time statistics (also of the frames drawn "
                 "while the pipeline ran)")
      ->check(CLI::Range(0, 100000));
  try {
    app.parse(argc, argv);
    if (!parse_view_mode(view_mode, o.view.mode)) throw CLI::ValidationError("--view", view_mode);
    if (!parse_size(window_size, o.width, o.height))
      throw CLI::ValidationError("--window", "expected WxH, e.g. 1280x800");
    if (!overlays.empty()) {
      o.view.overlays = {false, false, false, false, false, false, false, false};
      for (const std::string& name : overlays)
        if (name != "none" && !cvt::render::set_overlay(o.view.overlays, name, true))
          throw CLI::ValidationError("--overlay", "unknown overlay '" + name + "'");
    }
    for (const std::string& chord : o.press) {
      int key;
      bool ctrl, shift;
      if (!parse_key_chord(chord, key, ctrl, shift))
        throw CLI::ValidationError("--press", "unknown key '" + chord + "'");
    }
    if (!colour_by.empty()) {
      cvt::Measure m;
      if (colour_by == "none")
        o.view.color_by.reset();
      else if (cvt::render::measure_from_key(colour_by, m))
        o.view.color_by = m;
      else
        throw CLI::ValidationError("--colour-by", "unknown measure '" + colour_by + "'");
    }
    if (!highlight.empty()) {
      const auto colon = highlight.find(':');
      cvt::Measure m;
      const int bin = colon == std::string::npos ? -1 : std::atoi(highlight.c_str() + colon + 1);
      if (colon == std::string::npos ||
          !cvt::render::measure_from_key(highlight.substr(0, colon), m) || bin < 0 || bin > 2)
        throw CLI::ValidationError("--highlight", "expected MEASURE:BIN, e.g. v_over_rmc3:0");
      o.view.highlight.kind = cvt::render::TetSelection::Kind::table1_bin;
      o.view.highlight.measure = m;
      o.view.highlight.index = bin;
    }
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (!run_through.empty()) o.run_through = *cvt::stage_from_key(run_through);
  if (clip >= 0) o.view.clip_enabled = true, o.view.clip_position = clip;
  if (!screenshot.empty())
    o.screenshot = ScreenshotRequest{screenshot, scale, transparent, include_ui};
  return run_viewer(o);
}
