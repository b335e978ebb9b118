// The viewer's Dear ImGui windows: menu bar, pipeline, quality and view panels, file dialogs,
// help, status line and the legends drawn over the views. Each draw_* function is called once
// per frame between ImGui::NewFrame and ImGui::Render.
#pragma once

#include <optional>
#include <string>

#include "scene_renderer.h"
#include "session.h"
#include "view_settings.h"

namespace cvt::gui {

struct ScreenshotRequest {
  std::string path;
  int scale = 1;             // 1–4 × the window size
  bool transparent = false;  // transparent background
  bool include_ui = false;   // the whole window (panels too), not just the views and legends
};

// A path field with a folder listing below it, shared by every file dialog.
struct FileDialog {
  bool open = false;
  std::string folder;           // listed folder
  std::string path;             // the chosen path (editable)
  bool choose_folders = false;  // "Open folder" for DICOM series and slice folders
};

// Which windows are open, and the dialogs' fields.
struct UiState {
  bool show_pipeline = true, show_quality = true, show_view = true, show_help = false;
  bool show_messages = false;
  double frame_ms = 0;  // work of the last frame (not the wait for events), for the status bar
  FileDialog open_image, export_mesh, load_preset, save_preset, screenshot;
  int screenshot_scale = 1;
  bool screenshot_transparent = false;
  std::optional<ScreenshotRequest> screenshot_request;  // taken after this frame renders
  bool quit = false;
  // Where the panels sit (set by the viewer each frame, from which ones are shown): pinned
  // columns left and right of the views, so no panel hides the views.
  Rect pipeline_panel, quality_panel, view_panel;
  bool fit_3d = false, fit_slice = false;  // requests for the renderer
  double now_s = 0;                        // for parameter edit timing
};

inline constexpr float kLeftPanelWidth = 370, kRightPanelWidth = 390;

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
// Opens the window or dialog called `name` (help, messages, open, export, load-preset,
// save-preset, screenshot); false for an unknown name. For scripted screenshots of the UI.
bool show_window(UiState& ui, const std::string& name);
void draw_status_bar(UiContext& ctx);
// Legends and captions over the views, in windows named "legend…" so a screenshot can draw
// them too (see screenshot.cpp).
void draw_legends(UiContext& ctx, const ViewRects& rects);
// Keyboard shortcuts (when no text field has the keyboard).
void handle_shortcuts(UiContext& ctx);

// The list of shortcuts, shown in the help window (key, action).
struct Shortcut {
  const char* keys;
  const char* action;
};
const std::vector<Shortcut>& shortcuts();

}  // namespace cvt::gui
