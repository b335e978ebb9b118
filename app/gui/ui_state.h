// The viewer's UI state that is not drawing: which windows are open, the file dialogs' fields,
// requests for the next frame. GL-free, so the input actions that change it are unit tested.
#pragma once

#include <optional>
#include <string>

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

}  // namespace cvt::gui
