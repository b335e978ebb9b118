// What the user's inputs do, apart from the widgets that draw them: the keyboard bindings (one
// table, which the help window lists and handle_shortcuts reads, so the two cannot disagree),
// the actions they trigger, the file dialogs' folder listing and confirmation, files dropped on
// the window, and the image and runs given on the command line. GL-free (key codes are GLFW's
// constants), so every input path is unit tested without a window.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "session.h"
#include "ui_state.h"
#include "view_settings.h"

namespace cvt::gui {

enum class Action {
  open_image, export_mesh, load_preset, save_preset, screenshot, quit,
  run_all, rerun_stale, run_next_stage, lloyd_step, lloyd_10, lloyd_converge,
  optimize_pass, optimize_to_end, cancel,
  cycle_view, sagittal, coronal, axial, slice_up, slice_down, slice_up_10, slice_down_10,
  fit_views, toggle_clip, flip_clip, toggle_help, toggle_panels,
};

struct KeyBinding {
  int key;  // GLFW_KEY_*
  bool ctrl = false, shift = false;  // exactly these modifiers
  Action action;
  bool repeat = false;  // also on key repeat while held
};

const std::vector<KeyBinding>& key_bindings();
// The action bound to a key with exactly these modifiers, if any.
std::optional<Action> action_for_key(int key, bool ctrl, bool shift);
// "Ctrl+O", "Shift+L", "F12", "PgUp".
std::string key_label(const KeyBinding& binding);
const char* action_description(Action action);
// "ctrl+r", "Shift+O", "f1", "pgdn" (case-insensitive): a key that has a binding, with any
// modifiers; false for anything else. For scripted key presses.
bool parse_key_chord(const std::string& text, int& key, bool& ctrl, bool& shift);

// The help window's lines: one per key binding (its label and description), then the mouse.
struct HelpLine {
  std::string keys, action;
};
std::vector<HelpLine> help_lines();

// Does what the action says (actions that need an image or a mesh, or an idle worker, do
// nothing without one).
void perform(Action action, Session& session, ViewSettings& view, UiState& ui);

// Opens a file dialog (listing the working folder the first time) with a suggested path.
void open_dialog(FileDialog& dialog, const std::string& suggestion);
// Opens the window or dialog called `name` (help, messages, open, export, load-preset,
// save-preset, screenshot); false for an unknown name. For scripted screenshots of the UI.
bool show_window(UiState& ui, const std::string& name);

// A dialog's folder listing: sub-folders, then files whose name ends with one of `extensions`
// (any when empty; case-insensitive), each sorted by name; hidden entries left out.
struct FolderListing {
  std::vector<std::string> folders, files;  // full paths
  std::string error;                        // why the folder could not be listed
};
FolderListing list_folder(const std::string& folder, const std::vector<std::string>& extensions);
const std::vector<std::string>& image_extensions();

enum class Dialog { open_image, export_mesh, load_preset, save_preset, screenshot };
// The dialog's confirm button (or Enter in its path field, or a double click on a file): acts
// on its path and closes it. An empty path does nothing.
void confirm_dialog(Dialog dialog, Session& session, UiState& ui);

// Paths dropped on the window (GLFW's drop callback collects them): the first is opened, the
// others are named in a message. Clears `paths`.
void open_dropped(Session& session, std::vector<std::string>& paths);

// The image and runs given on the command line.
struct StartRequest {
  std::string image;                 // opened first (empty: none, and nothing runs)
  bool run_all = false;              // every stage
  std::optional<Stage> run_through;  // or the stages up to this one
  // Stage 6 passes, one job each (< 0: to the end; 0: none). With run_all or run_through:
  // stages 1-4 first, then the passes; with run_all, then what is left.
  int optimize_passes = 0;
};
void start_session(Session& session, const StartRequest& request);

}  // namespace cvt::gui
