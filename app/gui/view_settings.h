// What the views show, set from the panels, the keyboard and the scripted-mode options, plus
// the small decisions the pipeline panel makes (which stages are stale, what re-running runs,
// when to auto re-run). GL-free, so it is unit tested.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "evaluate/quality.h"
#include "quality_selection.h"
#include "scene_data.h"
#include "slice_image.h"

namespace cvt::gui {

enum class ViewMode { view3d, slice, split };
// "3d", "slice", "split" (false for anything else).
bool parse_view_mode(const std::string& text, ViewMode& out);

struct ViewSettings {
  ViewMode mode = ViewMode::split;
  int slice_axis = 2;    // 0 sagittal (i), 1 coronal (j), 2 axial (k)
  int slice_index = -1;  // image voxel index; −1 = the middle of the object
  render::Overlays overlays;
  std::optional<render::WindowLevel> window_level;  // unset: the image's full range
  bool clip_enabled = false;                        // remove the tets beyond the clip plane
  int clip_axis = 1;                                // world axis the plane is perpendicular to
  double clip_position = 0.5;                       // fraction of the mesh box along that axis
  bool clip_flip = false;  // remove the tets above the plane instead of below
  std::optional<Measure> color_by = Measure::VOverRmc3;  // colour of the cut faces
  bool color_boundary = false;  // colour the boundary faces by the measure too
  bool show_surface = true;
  bool show_points = true;
  bool show_slice_plane = false;  // the slice image placed in the 3D view
  bool edges = true;
  float point_size_px = 4.0f;
  render::TetSelection highlight;       // tets selected in the quality panel
  bool transparent_background = false;  // for screenshots
  bool operator==(const ViewSettings&) const = default;
};

// Which kinds of points the 3D view draws. With a mesh on screen, B and I are its vertices
// (the edges show them) and the shallow points lie inside its kept tets; with an unclipped
// surface, I and the shallow points are hidden inside it. Hidden points are not drawn at all
// (a software rasteriser pays for every sprite); the exterior poles always show.
struct PointsShown {
  bool samples = false, interior = false, shallow = false, poles = false;
};
PointsShown points_shown_3d(const ViewSettings& view, bool has_surface, bool has_mesh);

// The slice index to show: the setting if valid, else the middle of the object (or image).
int effective_slice_index(const ViewSettings& view, const render::SceneData& scene);

// How the pipeline panel marks a stage.
enum class StageState {
  done,     // has run with the applied parameters, and no edit changes it
  pending,  // done, but an edited (not yet applied) parameter changes it
  stale,    // not run with the current parameters (or never)
};
// First stage the edited parameters change relative to the applied ones (count if none), as
// the parameter registry tracks it.
Stage first_edited_stage(const render::SceneData* scene, const Parameters& edited);
std::array<StageState, kStageCount> stage_states(const render::SceneData* scene,
                                                 const Parameters& edited);

// The stages "re-run stale" runs: every non-done stage up to `target` (the furthest stage the
// user has asked for), in order.
std::vector<Stage> stages_to_rerun(const std::array<StageState, kStageCount>& states, Stage target);

// Auto re-run starts when it is on, edits are pending, nothing runs, and the last edit is at
// least `quiet_s` seconds old (so dragging a slider does not start a run per frame).
bool should_auto_rerun(bool enabled, bool edits_pending, bool worker_busy, double since_edit_s,
                       double quiet_s = 0.6);

}  // namespace cvt::gui

namespace cvt::gui {

// A view's rectangle in window coordinates (origin top-left).
struct Rect {
  float x = 0, y = 0, w = 0, h = 0;
  bool empty() const { return w <= 0 || h <= 0; }
  bool contains(float px, float py) const { return px >= x && py >= y && px < x + w && py < y + h; }
  bool operator==(const Rect&) const = default;
};
struct ViewRects {
  Rect view3d, slice;  // an empty rect: that view is hidden
  bool operator==(const ViewRects&) const = default;
};
// 3D only, slice only, or both in `area`: side by side (3D left) in a wide area, one above
// the other (3D on top) in a tall one.
ViewRects view_rects(ViewMode mode, const Rect& area);

// Where the views go in a window of width × height: what the side panels, the menu bar and
// the status bar leave (panel widths 0 when hidden).
Rect views_area(float width, float height, float left_panel, float right_panel, float top_bar,
                float bottom_bar);

}  // namespace cvt::gui
