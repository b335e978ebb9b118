#include "view_settings.h"

#include <algorithm>
#include <cmath>

#include "pipeline/parameter_registry.h"

namespace cvt::gui {

bool parse_view_mode(const std::string& text, ViewMode& out) {
  if (text == "3d")
    out = ViewMode::view3d;
  else if (text == "slice")
    out = ViewMode::slice;
  else if (text == "split")
    out = ViewMode::split;
  else
    return false;
  return true;
}

PointsShown points_shown_3d(const ViewSettings& view, bool has_surface, bool has_mesh) {
  PointsShown p;
  if (!view.show_points) return p;
  const render::Overlays& o = view.overlays;
  const bool mesh_shown = has_mesh && view.show_surface;
  const bool inside_hidden = view.show_surface && (has_surface || has_mesh) && !view.clip_enabled;
  p.samples = o.samples && !mesh_shown;
  p.interior = o.interior && !mesh_shown && !inside_hidden;
  p.shallow = o.shallow && !mesh_shown && !inside_hidden;
  p.poles = o.poles;
  return p;
}

int effective_slice_index(const ViewSettings& view, const render::SceneData& scene) {
  if (!scene.image) return 0;
  const int n = scene.image->grid().dims[view.slice_axis];
  if (view.slice_index >= 0 && view.slice_index < n) return view.slice_index;
  if (scene.volumes) {
    const auto& v = *scene.volumes;
    return std::clamp(v.offset[view.slice_axis] + v.grid.dims[view.slice_axis] / 2, 0, n - 1);
  }
  return n / 2;
}

Stage first_edited_stage(const render::SceneData* scene, const Parameters& edited) {
  if (!scene) return Stage::count;
  return first_changed_stage(scene->parameters, edited);
}

std::array<StageState, kStageCount> stage_states(const render::SceneData* scene,
                                                 const Parameters& edited) {
  std::array<StageState, kStageCount> states;
  states.fill(StageState::stale);
  if (!scene) return states;
  const int edited_from = int(first_edited_stage(scene, edited));
  for (int s = 0; s < kStageCount; ++s) {
    if (scene->stale[s]) continue;
    states[s] = s >= edited_from ? StageState::pending : StageState::done;
  }
  return states;
}

std::vector<Stage> stages_to_rerun(const std::array<StageState, kStageCount>& states,
                                   Stage target) {
  std::vector<Stage> out;
  for (int s = 0; s <= int(target) && s < kStageCount; ++s)
    if (states[s] != StageState::done) out.push_back(Stage(s));
  return out;
}

bool should_auto_rerun(bool enabled, bool edits_pending, bool worker_busy, double since_edit_s,
                       double quiet_s) {
  return enabled && edits_pending && !worker_busy && since_edit_s >= quiet_s;
}

}  // namespace cvt::gui

namespace cvt::gui {

ViewRects view_rects(ViewMode mode, const Rect& a) {
  switch (mode) {
    case ViewMode::view3d:
      return {a, {}};
    case ViewMode::slice:
      return {{}, a};
    case ViewMode::split: {
      // Along the longer side, so each view stays as square as it can.
      if (a.w >= a.h) {
        const float half = std::floor(0.5f * a.w);
        return {{a.x, a.y, half, a.h}, {a.x + half, a.y, a.w - half, a.h}};
      }
      const float half = std::floor(0.5f * a.h);
      return {{a.x, a.y, a.w, half}, {a.x, a.y + half, a.w, a.h - half}};
    }
  }
  return {};
}

Rect views_area(float width, float height, float left_panel, float right_panel, float top_bar,
                float bottom_bar) {
  Rect r{left_panel, top_bar, width - left_panel - right_panel, height - top_bar - bottom_bar};
  // Panels wider than the window: fall back to the whole window under the panels.
  if (r.w < 64 || r.h < 64) r = {0, top_bar, width, std::max(height - top_bar - bottom_bar, 1.0f)};
  return r;
}

}  // namespace cvt::gui
