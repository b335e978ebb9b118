// The menu bar, the status bar (job progress, Cancel, the latest message), keyboard shortcuts
// and the help window that lists them.
#include <imgui.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cmath>
#include <filesystem>

#include "ui.h"

namespace cvt::gui {
namespace {

void open_dialog(FileDialog& d, const std::string& suggestion) {
  d.open = true;
  if (d.folder.empty()) d.folder = std::filesystem::current_path().string();
  if (d.path.empty()) d.path = suggestion;
}

void cycle_view(ViewSettings& v) {
  v.mode = v.mode == ViewMode::split    ? ViewMode::view3d
           : v.mode == ViewMode::view3d ? ViewMode::slice
                                        : ViewMode::split;
}

}  // namespace

void layout_panels(UiState& ui, float width, float height, float top_bar, float bottom_bar) {
  const float h = height - top_bar - bottom_bar;
  ui.pipeline_panel = {0, top_bar, kLeftPanelWidth, h};
  const float x = width - kRightPanelWidth;
  const float quality_h = ui.show_view ? std::floor(0.58f * h) : h;
  ui.quality_panel = {x, top_bar, kRightPanelWidth, quality_h};
  ui.view_panel = ui.show_quality ? Rect{x, top_bar + quality_h, kRightPanelWidth, h - quality_h}
                                  : Rect{x, top_bar, kRightPanelWidth, h};
}

const std::vector<Shortcut>& shortcuts() {
  static const std::vector<Shortcut> list{
      {"Ctrl+O", "open an image"},
      {"Ctrl+E", "export the mesh"},
      {"Ctrl+P / Ctrl+S", "load / save a preset"},
      {"F12", "screenshot"},
      {"Ctrl+R", "run all stages"},
      {"R", "re-run stale stages"},
      {"N", "run the next stage"},
      {"L / Shift+L / Ctrl+L", "Lloyd: 1 step / 10 steps / to convergence"},
      {"Esc", "cancel the running job"},
      {"Tab", "3D / slice / both"},
      {"1 2 3", "sagittal / coronal / axial slice"},
      {"Up Down, PgUp PgDn", "slice index by 1, by 10"},
      {"F", "fit the views"},
      {"C / Shift+C", "clip on/off / flip the clip side"},
      {"F1 or H", "this help"},
      {"F2", "hide / show the panels"},
      {"Ctrl+Q", "quit"},
      {"3D mouse", "left drag: orbit, right or Shift+left drag: pan, wheel: zoom"},
      {"slice mouse", "left drag: pan, wheel: zoom, Ctrl+wheel: slice, right drag: window/level"},
  };
  return list;
}

void draw_menu_bar(UiContext& ctx) {
  if (!ImGui::BeginMainMenuBar()) return;
  Session& s = ctx.session;
  UiState& ui = ctx.ui;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("Open image...", "Ctrl+O")) open_dialog(ui.open_image, "");
    if (ImGui::BeginMenu("Recent", !s.recent().files().empty())) {
      for (const std::string& f : s.recent().files())
        if (ImGui::MenuItem(f.c_str())) s.open_image(f);
      ImGui::EndMenu();
    }
    ImGui::Separator();
    const bool has_mesh = s.scene() && s.scene()->mesh;
    if (ImGui::MenuItem("Export mesh...", "Ctrl+E", false, has_mesh))
      open_dialog(ui.export_mesh, "mesh.vtu");
    if (ImGui::MenuItem("Load preset...", "Ctrl+P")) open_dialog(ui.load_preset, "");
    if (ImGui::MenuItem("Save preset...", "Ctrl+S")) open_dialog(ui.save_preset, "preset.json");
    if (ImGui::MenuItem("Screenshot...", "F12")) open_dialog(ui.screenshot, "cvtmesh.png");
    ImGui::Separator();
    if (ImGui::MenuItem("Quit", "Ctrl+Q")) ui.quit = true;
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Run")) {
    const bool can = !s.busy() && s.scene() && s.scene()->image;
    if (ImGui::MenuItem("Run all", "Ctrl+R", false, can)) s.run_all();
    if (ImGui::MenuItem("Re-run stale", "R", false, can)) s.rerun_stale();
    if (ImGui::MenuItem("Run next stage", "N", false, can)) s.run_next_stage();
    for (int st = 0; st < kStageCount; ++st) {
      const std::string label = "Run through " + std::string(stage_name(Stage(st)));
      if (ImGui::MenuItem(label.c_str(), nullptr, false, can)) s.run_through(Stage(st));
    }
    ImGui::Separator();
    if (ImGui::MenuItem("Lloyd step", "L", false, can)) s.step_lloyd(1);
    if (ImGui::MenuItem("Lloyd 10 steps", "Shift+L", false, can)) s.step_lloyd(10);
    if (ImGui::MenuItem("Lloyd to convergence", "Ctrl+L", false, can)) s.step_lloyd(-1);
    ImGui::MenuItem("Auto re-run", nullptr, &s.auto_rerun);
    if (ImGui::MenuItem("Cancel", "Esc", false, s.busy())) s.cancel();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Windows")) {
    ImGui::MenuItem("Pipeline", nullptr, &ui.show_pipeline);
    ImGui::MenuItem("Quality", nullptr, &ui.show_quality);
    ImGui::MenuItem("View", nullptr, &ui.show_view);
    ImGui::MenuItem("Messages", nullptr, &ui.show_messages);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Help")) {
    ImGui::MenuItem("Shortcuts", "F1", &ui.show_help);
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();
}

void draw_status_bar(UiContext& ctx) {
  const ImGuiIO& io = ImGui::GetIO();
  const float h = ImGui::GetFrameHeight() + 8;
  ImGui::SetNextWindowPos(ImVec2(0, io.DisplaySize.y - h));
  ImGui::SetNextWindowSize(ImVec2(io.DisplaySize.x, h));
  ImGui::SetNextWindowBgAlpha(0.85f);
  ImGui::Begin("status", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoSavedSettings |
                   ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav);
  const WorkerStatus st = ctx.session.worker_status();
  if (st.busy) {
    ImGui::Text("%s", st.job.c_str());
    ImGui::SameLine();
    ImGui::SetNextItemWidth(220);
    char overlay[160];
    std::snprintf(overlay, sizeof overlay, "%s", st.step.c_str());
    ImGui::ProgressBar(float(st.fraction), ImVec2(220, 0), overlay);
    ImGui::SameLine();
    ImGui::Text("%.1f s%s", st.elapsed_s,
                st.queued ? (", " + std::to_string(st.queued) + " queued").c_str() : "");
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) ctx.session.cancel();
    ImGui::SameLine();
  }
  if (!ctx.session.messages.empty()) {
    const Message& m = ctx.session.messages.back();
    // Errors stay red in the status bar until the next message; all are in Windows > Messages.
    if (m.error)
      ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "error: %s", m.text.c_str());
    else
      ImGui::TextDisabled("%s", m.text.c_str());
    if (ImGui::IsItemClicked()) ctx.ui.show_messages = true;
  }
  ImGui::SameLine(std::max(ImGui::GetCursorPosX(), io.DisplaySize.x - 120));
  ImGui::TextDisabled("frame %.1f ms", ctx.ui.frame_ms);
  ImGui::End();
}

void draw_messages_window(UiContext& ctx) {
  if (!ctx.ui.show_messages) return;
  ImGui::SetNextWindowSize(ImVec2(640, 300), ImGuiCond_FirstUseEver);
  if (ImGui::Begin("Messages", &ctx.ui.show_messages)) {
    for (const Message& m : ctx.session.messages) {
      if (m.error)
        ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "error: %s", m.text.c_str());
      else
        ImGui::TextUnformatted(m.text.c_str());
    }
    if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY()) ImGui::SetScrollHereY(1.0f);
  }
  ImGui::End();
}

bool show_window(UiState& ui, const std::string& name) {
  if (name == "help")
    ui.show_help = true;
  else if (name == "messages")
    ui.show_messages = true;
  else if (name == "open")
    open_dialog(ui.open_image, "");
  else if (name == "export")
    open_dialog(ui.export_mesh, "mesh.vtu");
  else if (name == "load-preset")
    open_dialog(ui.load_preset, "");
  else if (name == "save-preset")
    open_dialog(ui.save_preset, "preset.json");
  else if (name == "screenshot")
    open_dialog(ui.screenshot, "cvtmesh.png");
  else
    return false;
  return true;
}

void draw_help_window(UiContext& ctx) {
  if (!ctx.ui.show_help) return;
  ImGui::SetNextWindowSize(ImVec2(720, 0), ImGuiCond_FirstUseEver);
  if (ImGui::Begin("Help", &ctx.ui.show_help)) {
    ImGui::TextWrapped(
        "cvtmesh-gui meshes the object of a 3D segmentation: preprocess, surface sampling, "
        "CVT interior sampling, shallow-point removal, Delaunay mesh, evaluation. Change a "
        "parameter and the stages it affects turn orange; re-run them with R.");
    if (ImGui::BeginTable("keys", 2, ImGuiTableFlags_RowBg)) {
      ImGui::TableSetupColumn("keys", ImGuiTableColumnFlags_WidthFixed, 190);
      ImGui::TableSetupColumn("action", ImGuiTableColumnFlags_WidthStretch);
      for (const Shortcut& s : shortcuts()) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(s.keys);
        ImGui::TableNextColumn();
        ImGui::TextWrapped("%s", s.action);
      }
      ImGui::EndTable();
    }
  }
  ImGui::End();
}

void handle_shortcuts(UiContext& ctx) {
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput) return;
  Session& s = ctx.session;
  ViewSettings& v = ctx.view;
  UiState& ui = ctx.ui;
  auto pressed = [](int key) { return ImGui::IsKeyPressed(key, false); };
  auto repeat = [](int key) { return ImGui::IsKeyPressed(key, true); };
  const bool ctrl = io.KeyCtrl, shift = io.KeyShift;
  const bool can_run = !s.busy() && s.scene() && s.scene()->image;
  if (ctrl) {
    if (pressed(GLFW_KEY_O)) open_dialog(ui.open_image, "");
    if (pressed(GLFW_KEY_E) && s.scene() && s.scene()->mesh)
      open_dialog(ui.export_mesh, "mesh.vtu");
    if (pressed(GLFW_KEY_P)) open_dialog(ui.load_preset, "");
    if (pressed(GLFW_KEY_S)) open_dialog(ui.save_preset, "preset.json");
    if (pressed(GLFW_KEY_R) && can_run) s.run_all();
    if (pressed(GLFW_KEY_L) && can_run) s.step_lloyd(-1);
    if (pressed(GLFW_KEY_Q)) ui.quit = true;
    return;
  }
  if (pressed(GLFW_KEY_F12)) open_dialog(ui.screenshot, "cvtmesh.png");
  if (pressed(GLFW_KEY_F1) || pressed(GLFW_KEY_H)) ui.show_help = !ui.show_help;
  if (pressed(GLFW_KEY_F2)) {
    const bool any = ui.show_pipeline || ui.show_quality || ui.show_view;
    ui.show_pipeline = ui.show_quality = ui.show_view = !any;
    ui.fit_slice = true;
  }
  if (pressed(GLFW_KEY_ESCAPE)) s.cancel();
  if (pressed(GLFW_KEY_R) && can_run) s.rerun_stale();
  if (pressed(GLFW_KEY_N) && can_run) s.run_next_stage();
  if (pressed(GLFW_KEY_L) && can_run) s.step_lloyd(shift ? 10 : 1);
  if (pressed(GLFW_KEY_TAB)) cycle_view(v), ui.fit_slice = true;
  for (int a = 0; a < 3; ++a)
    if (pressed(GLFW_KEY_1 + a)) v.slice_axis = a, v.slice_index = -1;
  if (pressed(GLFW_KEY_F)) ui.fit_3d = ui.fit_slice = true;
  if (pressed(GLFW_KEY_C)) {
    if (shift)
      v.clip_flip = !v.clip_flip;
    else
      v.clip_enabled = !v.clip_enabled;
  }
  if (s.scene() && s.scene()->image) {
    const int n = s.scene()->image->grid().dims[v.slice_axis];
    int step = 0;
    if (repeat(GLFW_KEY_UP)) step = 1;
    if (repeat(GLFW_KEY_DOWN)) step = -1;
    if (repeat(GLFW_KEY_PAGE_UP)) step = 10;
    if (repeat(GLFW_KEY_PAGE_DOWN)) step = -10;
    if (step) v.slice_index = std::clamp(effective_slice_index(v, *s.scene()) + step, 0, n - 1);
  }
}

}  // namespace cvt::gui
