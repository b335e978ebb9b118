// The menu bar, the status bar (job progress, Cancel, the latest message), keyboard shortcuts
// and the help window that lists them.
#include <imgui.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cmath>
#include <filesystem>

#include "input_actions.h"
#include "ui.h"

namespace cvt::gui {

void layout_panels(UiState& ui, float width, float height, float top_bar, float bottom_bar) {
  const float h = height - top_bar - bottom_bar;
  ui.pipeline_panel = {0, top_bar, kLeftPanelWidth, h};
  const float x = width - kRightPanelWidth;
  const float quality_h = ui.show_view ? std::floor(0.58f * h) : h;
  ui.quality_panel = {x, top_bar, kRightPanelWidth, quality_h};
  ui.view_panel = ui.show_quality ? Rect{x, top_bar + quality_h, kRightPanelWidth, h - quality_h}
                                  : Rect{x, top_bar, kRightPanelWidth, h};
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
    ImGui::Separator();
    if (ImGui::MenuItem("Optimise one pass", "O", false, can)) s.step_optimization(1);
    if (ImGui::MenuItem("Optimise to the end", "Shift+O", false, can)) s.step_optimization(-1);
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
      for (const HelpLine& line : help_lines()) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(line.keys.c_str());
        ImGui::TableNextColumn();
        ImGui::TextWrapped("%s", line.action.c_str());
      }
      ImGui::EndTable();
    }
  }
  ImGui::End();
}

void handle_shortcuts(UiContext& ctx) {
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput) return;
  for (const KeyBinding& b : key_bindings())
    if (b.ctrl == io.KeyCtrl && b.shift == io.KeyShift && ImGui::IsKeyPressed(b.key, b.repeat))
      perform(b.action, ctx.session, ctx.view, ctx.ui);
}

}  // namespace cvt::gui
