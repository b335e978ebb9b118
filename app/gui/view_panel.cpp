// The view panel: which view, the slice (axis, index, window/level), overlays, and the 3D
// options (surface, points, clip plane, colour by a quality measure).
#include <imgui.h>

#include "input_actions.h"
#include "ui.h"

namespace cvt::gui {

void draw_view_panel(UiContext& ctx) {
  if (!ctx.ui.show_view) return;
  const Rect& r = ctx.ui.view_panel;
  ImGui::SetNextWindowPos(ImVec2(r.x, r.y));
  ImGui::SetNextWindowSize(ImVec2(r.w, r.h));
  if (!ImGui::Begin(
          "View", &ctx.ui.show_view,
          ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse)) {
    ImGui::End();
    return;
  }
  ViewSettings& v = ctx.view;
  const render::SceneData* scene = ctx.session.scene();
  int mode = int(v.mode);
  ImGui::RadioButton("3D", &mode, int(ViewMode::view3d));
  ImGui::SameLine();
  ImGui::RadioButton("slice", &mode, int(ViewMode::slice));
  ImGui::SameLine();
  ImGui::RadioButton("both", &mode, int(ViewMode::split));
  if (mode != int(v.mode)) {
    v.mode = ViewMode(mode);
    ctx.ui.fit_slice = true;
  }

  if (ImGui::CollapsingHeader("Slice", ImGuiTreeNodeFlags_DefaultOpen)) {
    int axis = v.slice_axis;
    ImGui::RadioButton("sagittal (i)", &axis, 0);
    ImGui::SameLine();
    ImGui::RadioButton("coronal (j)", &axis, 1);
    ImGui::SameLine();
    ImGui::RadioButton("axial (k)", &axis, 2);
    if (axis != v.slice_axis) v.slice_axis = axis, v.slice_index = -1;
    if (scene && scene->image) {
      const int n = scene->image->grid().dims[v.slice_axis];
      int index = effective_slice_index(v, *scene);
      if (ImGui::SliderInt("index", &index, 0, n - 1)) v.slice_index = index;
      const render::WindowLevel full = render::default_window_level(scene->value_range);
      bool automatic = !v.window_level.has_value();
      if (ImGui::Checkbox("full range", &automatic))
        v.window_level = automatic ? std::nullopt : std::optional(full);
      if (v.window_level) {
        float window = float(v.window_level->window), level = float(v.window_level->level);
        const float lo = float(scene->value_range.min), hi = float(scene->value_range.max);
        bool changed = ImGui::SliderFloat("window", &window, 1e-3f, std::max(hi - lo, 1e-3f) * 2);
        changed |= ImGui::SliderFloat("level", &level, lo, hi);
        if (changed) v.window_level = render::WindowLevel{window, level};
      }
    }
    if (ImGui::Button("Fit slice")) ctx.ui.fit_slice = true;
  }
  if (ImGui::CollapsingHeader("Overlays", ImGuiTreeNodeFlags_DefaultOpen)) {
    render::Overlays& o = v.overlays;
    ImGui::Checkbox("object", &o.object);
    ImGui::SameLine(130);
    ImGui::Checkbox("lfs", &o.lfs);
    ImGui::SameLine(260);
    ImGui::Checkbox("medial axis", &o.medial);
    ImGui::Checkbox("samples B", &o.samples);
    ImGui::SameLine();
    ImGui::Checkbox("B unprojected", &o.voxel_samples);
    ImGui::SameLine(130);
    ImGui::Checkbox("interior I", &o.interior);
    ImGui::SameLine(260);
    ImGui::Checkbox("shallow", &o.shallow);
    ImGui::Checkbox("poles EP", &o.poles);
    ImGui::SameLine(130);
    ImGui::Checkbox("Voronoi cells", &o.voronoi);
  }
  if (ImGui::CollapsingHeader("3D", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Checkbox("surface / tets", &v.show_surface);
    ImGui::SameLine(130);
    ImGui::Checkbox("points", &v.show_points);
    ImGui::SameLine(260);
    ImGui::Checkbox("edges", &v.edges);
    ImGui::Checkbox("slice plane", &v.show_slice_plane);
    ImGui::SliderFloat("point size (px)", &v.point_size_px, 1.0f, 16.0f, "%.0f");
    ImGui::Checkbox("clip (whole tets)", &v.clip_enabled);
    ImGui::SameLine();
    ImGui::Checkbox("flip", &v.clip_flip);
    ImGui::RadioButton("x", &v.clip_axis, 0);
    ImGui::SameLine();
    ImGui::RadioButton("y", &v.clip_axis, 1);
    ImGui::SameLine();
    ImGui::RadioButton("z", &v.clip_axis, 2);
    ImGui::SameLine();
    ImGui::SetNextItemWidth(160);
    float position = float(v.clip_position);
    if (ImGui::SliderFloat("position", &position, 0.0f, 1.0f)) v.clip_position = position;
    const char* measures[] = {"none",         "V / r_mc^3",   "gradient error", "condition number",
                              "min dihedral", "max dihedral", "radius-edge"};
    int color = v.color_by ? int(*v.color_by) + 1 : 0;
    if (ImGui::Combo("colour by", &color, measures, 7))
      v.color_by = color == 0 ? std::nullopt : std::optional(Measure(color - 1));
    ImGui::Checkbox("colour the boundary too", &v.color_boundary);
    if (ctx.renderer.has_mesh)
      ImGui::Text("%zu tets kept, %zu cut faces", ctx.renderer.kept_tets, ctx.renderer.cut_faces);
    if (ImGui::Button("Fit 3D")) ctx.ui.fit_3d = true;
  }
  if (ImGui::Button("Screenshot...")) show_window(ctx.ui, "screenshot");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(80);
  ImGui::SliderInt("##screenshot scale", &ctx.ui.screenshot_scale, 1, 4, "%dx");
  ImGui::SameLine();
  ImGui::Checkbox("transparent", &ctx.ui.screenshot_transparent);
  ImGui::End();
}

}  // namespace cvt::gui
