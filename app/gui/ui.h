// The viewer's Dear ImGui windows: menu bar, pipeline, quality and view panels, file dialogs,
// help, status line and the legends drawn over the views. Each draw_* function is called once
// per frame between ImGui::NewFrame and ImGui::Render.
#pragma once

#include <optional>
#include <string>

#include "scene_renderer.h"
#include "session.h"
#include "ui_state.h"
#include "view_settings.h"

namespace cvt::gui {

// The panel rectangles for a window of width × height between the menu and status bars.
void layout_panels(UiState& ui, float width, float height, float top_bar, float bottom_bar);

struct UiContext {
  Session& session;
  ViewSettings& view;
  SceneRenderer& renderer;
  UiState& ui;
};

void draw_menu_bar(UiContext& ctx);
void draw_pipeline_panel(UiContext& ctx);
void draw_quality_panel(UiContext& ctx);
void draw_view_panel(UiContext& ctx);
void draw_file_dialogs(UiContext& ctx);
void draw_help_window(UiContext& ctx);
void draw_messages_window(UiContext& ctx);
void draw_status_bar(UiContext& ctx);
// Legends and captions over the views, in windows named "legend…" so a screenshot can draw
// them too (see screenshot.cpp).
void draw_legends(UiContext& ctx, const ViewRects& rects);
// Keyboard shortcuts (when no text field has the keyboard): key_bindings() of input_actions.h.
void handle_shortcuts(UiContext& ctx);


}  // namespace cvt::gui
