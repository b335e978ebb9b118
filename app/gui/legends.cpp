// Legends and captions drawn over the views: the quality colour bar of the 3D view, the lfs
// colour bar and the slice caption of the slice view, and a key of the point colours. They are
// ImGui windows named "legend…", which screenshot.cpp also draws into screenshots.
#include <imgui.h>

#include <cstdio>

#include "colormap.h"
#include "mesh_geometry.h"
#include "ui.h"

namespace cvt::gui {
namespace {

ImU32 to_imgui(render::Rgba8 c) {
  return IM_COL32(c.r, c.g, c.b, c.a);
}

constexpr ImGuiWindowFlags kLegendFlags =
    ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoInputs |
    ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav |
    ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoMove;

// A horizontal colour bar of `color(t)`, t ∈ [0, 1], with the end values under it.
template <class ColorOf>
void color_bar(const char* title, double lo, double hi, ColorOf color) {
  ImGui::TextUnformatted(title);
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float w = 220, h = 14;
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const int steps = 32;
  for (int i = 0; i < steps; ++i) {
    const float x0 = p.x + w * i / steps, x1 = p.x + w * (i + 1) / steps;
    const ImU32 a = to_imgui(color(double(i) / steps)), b = to_imgui(color(double(i + 1) / steps));
    dl->AddRectFilledMultiColor(ImVec2(x0, p.y), ImVec2(x1, p.y + h), a, b, b, a);
  }
  ImGui::Dummy(ImVec2(w, h));
  ImGui::Text("%-10.3g", lo);
  ImGui::SameLine(w - ImGui::CalcTextSize("0000000").x);
  ImGui::Text("%7.3g", hi);
}

void point_key(const char* name, render::Rgba8 c) {
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float r = ImGui::GetTextLineHeight() * 0.35f;
  ImGui::GetWindowDrawList()->AddCircleFilled(
      ImVec2(p.x + r + 1, p.y + ImGui::GetTextLineHeight() * 0.5f), r, to_imgui(c));
  ImGui::Dummy(ImVec2(2 * r + 4, ImGui::GetTextLineHeight()));
  ImGui::SameLine();
  ImGui::TextUnformatted(name);
}

void begin_legend(const char* name, const Rect& view, bool right) {
  const float margin = 10;
  ImGui::SetNextWindowPos(
      ImVec2(right ? view.x + view.w - margin : view.x + margin, view.y + view.h - margin - 24),
      ImGuiCond_Always, ImVec2(right ? 1.0f : 0.0f, 1.0f));
  ImGui::SetNextWindowBgAlpha(0.55f);
  ImGui::Begin(name, nullptr, kLegendFlags);
}

// The kinds of points a view shows (see points_shown_3d), with their colours.
void points_key(const render::SceneData& scene, const PointsShown& shown, bool medial) {
  if (shown.samples && scene.surface_samples) point_key("surface samples B", render::kSampleColor);
  if (shown.interior && scene.lloyd) point_key("interior samples I", render::kInteriorColor);
  if (shown.shallow && scene.shallow) point_key("shallow points (removed)", render::kShallowColor);
  if (shown.poles && scene.mesh) point_key("exterior poles EP", render::kPoleColor);
  if (medial && scene.volumes) {
    point_key("inner medial axis", {255, 60, 210, 255});
    point_key("outer medial axis", {60, 225, 255, 255});
  }
}

}  // namespace

void draw_legends(UiContext& ctx, const ViewRects& rects) {
  const render::SceneData* scene = ctx.session.scene();
  if (!scene || !scene->image) return;
  const ViewSettings& v = ctx.view;
  if (!rects.view3d.empty()) {
    begin_legend("legend 3d", rects.view3d, false);
    if (scene->mesh && v.color_by && v.show_surface) {
      const Measure m = *v.color_by;
      const render::MeasureScale s = render::measure_scale(m);
      char title[96];
      std::snprintf(title, sizeof title, "%s%s", std::string(measure_key(m)).c_str(),
                    v.color_boundary ? "" : " (cut faces)");
      color_bar(title, s.lo, s.hi,
                [&](double t) { return render::measure_color(m, s.lo + t * (s.hi - s.lo)); });
    }
    if (v.highlight.kind != render::TetSelection::Kind::none && scene->mesh)
      ImGui::Text("highlighted: %zu tets", ctx.renderer.highlighted_tets);
    if (scene->mesh)
      ImGui::Text("%zu of %zu tets%s", ctx.renderer.kept_tets, scene->mesh->mesh.tets.size(),
                  v.clip_enabled ? " (clipped)" : "");
    // Results drawn from before a parameter change say so.
    const auto states = ctx.session.stage_states();
    if (scene->mesh && states[int(Stage::optimize)] != StageState::done)
      ImGui::TextColored(ImVec4(1.0f, 0.7f, 0.25f, 1.0f), "mesh out of date: R re-runs");
    points_key(*scene, points_shown_3d(v, scene->volumes != nullptr, scene->mesh != nullptr),
               false);
    ImGui::End();
  }
  if (!rects.slice.empty()) {
    begin_legend("legend slice", rects.slice, true);
    static const char* axis_names[] = {"sagittal", "coronal", "axial"};
    ImGui::Text("%s slice %d / %d", axis_names[v.slice_axis], ctx.renderer.slice_index,
                scene->image->grid().dims[v.slice_axis] - 1);
    if (v.overlays.lfs && scene->volumes)
      color_bar("local feature size (mm)", scene->volumes->lfs_bounds.min_mm,
                scene->volumes->lfs_bounds.max_mm,
                [](double t) { return render::colormap_color(render::Colormap::Viridis, t); });
    if (v.overlays.voronoi && ctx.session.lloyd())
      ImGui::Text("Voronoi cells, Lloyd iteration %zu", ctx.session.lloyd()->history.size());
    const render::Overlays& o = v.overlays;
    if (o.voxel_samples && scene->surface_voxel_samples)
      point_key("B at voxel centres (unprojected)", render::kVoxelSampleColor);
    points_key(*scene, {o.samples, o.interior, o.shallow, o.poles}, o.medial);
    ImGui::End();
  }
}

}  // namespace cvt::gui
