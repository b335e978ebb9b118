#include "input_actions.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace cvt::gui {

const std::vector<KeyBinding>& key_bindings() {
  using A = Action;
  static const std::vector<KeyBinding> list{
      {GLFW_KEY_O, true, false, A::open_image},
      {GLFW_KEY_E, true, false, A::export_mesh},
      {GLFW_KEY_P, true, false, A::load_preset},
      {GLFW_KEY_S, true, false, A::save_preset},
      {GLFW_KEY_F12, false, false, A::screenshot},
      {GLFW_KEY_Q, true, false, A::quit},
      {GLFW_KEY_R, true, false, A::run_all},
      {GLFW_KEY_R, false, false, A::rerun_stale},
      {GLFW_KEY_N, false, false, A::run_next_stage},
      {GLFW_KEY_L, false, false, A::lloyd_step},
      {GLFW_KEY_L, false, true, A::lloyd_10},
      {GLFW_KEY_L, true, false, A::lloyd_converge},
      {GLFW_KEY_O, false, false, A::optimize_pass},
      {GLFW_KEY_O, false, true, A::optimize_to_end},
      {GLFW_KEY_ESCAPE, false, false, A::cancel},
      {GLFW_KEY_TAB, false, false, A::cycle_view},
      {GLFW_KEY_1, false, false, A::sagittal},
      {GLFW_KEY_2, false, false, A::coronal},
      {GLFW_KEY_3, false, false, A::axial},
      {GLFW_KEY_UP, false, false, A::slice_up, true},
      {GLFW_KEY_DOWN, false, false, A::slice_down, true},
      {GLFW_KEY_PAGE_UP, false, false, A::slice_up_10, true},
      {GLFW_KEY_PAGE_DOWN, false, false, A::slice_down_10, true},
      {GLFW_KEY_F, false, false, A::fit_views},
      {GLFW_KEY_C, false, false, A::toggle_clip},
      {GLFW_KEY_C, false, true, A::flip_clip},
      {GLFW_KEY_F1, false, false, A::toggle_help},
      {GLFW_KEY_H, false, false, A::toggle_help},
      {GLFW_KEY_F2, false, false, A::toggle_panels},
  };
  return list;
}

std::optional<Action> action_for_key(int key, bool ctrl, bool shift) {
  for (const KeyBinding& b : key_bindings())
    if (b.key == key && b.ctrl == ctrl && b.shift == shift) return b.action;
  return std::nullopt;
}

namespace {

std::string key_name(int key) {
  if (key >= GLFW_KEY_A && key <= GLFW_KEY_Z) return std::string(1, char('A' + key - GLFW_KEY_A));
  if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) return std::string(1, char('0' + key - GLFW_KEY_0));
  if (key >= GLFW_KEY_F1 && key <= GLFW_KEY_F25) {
    std::string name = "F";  // (not "F" + to_string: GCC 12 warns falsely about that)
    name += std::to_string(key - GLFW_KEY_F1 + 1);
    return name;
  }
  switch (key) {
    case GLFW_KEY_ESCAPE: return "Esc";
    case GLFW_KEY_TAB: return "Tab";
    case GLFW_KEY_UP: return "Up";
    case GLFW_KEY_DOWN: return "Down";
    case GLFW_KEY_PAGE_UP: return "PgUp";
    case GLFW_KEY_PAGE_DOWN: return "PgDn";
  }
  std::string name = "key ";
  name += std::to_string(key);
  return name;
}

std::string lower(std::string t) {
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  return t;
}

}  // namespace

std::string key_label(const KeyBinding& b) {
  std::string label;
  if (b.ctrl) label += "Ctrl+";
  if (b.shift) label += "Shift+";
  label += key_name(b.key);
  return label;
}

bool parse_key_chord(const std::string& text, int& key, bool& ctrl, bool& shift) {
  std::string rest = lower(text);
  ctrl = shift = false;
  for (;;) {
    if (rest.rfind("ctrl+", 0) == 0)
      ctrl = true, rest = rest.substr(5);
    else if (rest.rfind("shift+", 0) == 0)
      shift = true, rest = rest.substr(6);
    else
      break;
  }
  for (const KeyBinding& b : key_bindings())
    if (lower(key_name(b.key)) == rest) {
      key = b.key;
      return true;
    }
  return false;
}

const char* action_description(Action a) {
  switch (a) {
    case Action::open_image: return "open an image";
    case Action::export_mesh: return "export the mesh";
    case Action::load_preset: return "load a preset";
    case Action::save_preset: return "save a preset";
    case Action::screenshot: return "screenshot";
    case Action::quit: return "quit";
    case Action::run_all: return "run all stages";
    case Action::rerun_stale: return "re-run stale stages";
    case Action::run_next_stage: return "run the next stage";
    case Action::lloyd_step: return "Lloyd: one iteration";
    case Action::lloyd_10: return "Lloyd: 10 iterations";
    case Action::lloyd_converge: return "Lloyd: to convergence";
    case Action::optimize_pass: return "optimisation (stage 6): one pass";
    case Action::optimize_to_end: return "optimisation (stage 6): to the end";
    case Action::cancel: return "cancel the running job";
    case Action::cycle_view: return "3D / slice / both";
    case Action::sagittal: return "sagittal slice";
    case Action::coronal: return "coronal slice";
    case Action::axial: return "axial slice";
    case Action::slice_up: return "next slice";
    case Action::slice_down: return "previous slice";
    case Action::slice_up_10: return "10 slices on";
    case Action::slice_down_10: return "10 slices back";
    case Action::fit_views: return "fit the views";
    case Action::toggle_clip: return "clip plane on / off";
    case Action::flip_clip: return "flip the clipped side";
    case Action::toggle_help: return "this help";
    case Action::toggle_panels: return "hide / show the panels";
  }
  return "?";
}

std::vector<HelpLine> help_lines() {
  std::vector<HelpLine> lines;
  for (const KeyBinding& b : key_bindings())
    lines.push_back({key_label(b), action_description(b.action)});
  lines.push_back({"3D mouse", "left drag: orbit, right or Shift+left drag: pan, wheel: zoom"});
  lines.push_back(
      {"slice mouse", "left drag: pan, wheel: zoom, Ctrl+wheel: slice, right drag: window/level"});
  lines.push_back({"drop a file", "open it (image file or DICOM / slice folder)"});
  return lines;
}

void open_dialog(FileDialog& d, const std::string& suggestion) {
  d.open = true;
  if (d.folder.empty()) d.folder = std::filesystem::current_path().string();
  if (d.path.empty()) d.path = suggestion;
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

void perform(Action a, Session& s, ViewSettings& v, UiState& ui) {
  const render::SceneData* scene = s.scene();
  const bool has_image = scene && scene->image;
  const bool can_run = !s.busy() && has_image;
  auto step_slice = [&](int step) {
    if (!has_image) return;
    const int n = scene->image->grid().dims[v.slice_axis];
    v.slice_index = std::clamp(effective_slice_index(v, *scene) + step, 0, n - 1);
  };
  switch (a) {
    case Action::open_image: open_dialog(ui.open_image, ""); break;
    case Action::export_mesh:
      if (scene && scene->mesh) open_dialog(ui.export_mesh, "mesh.vtu");
      break;
    case Action::load_preset: open_dialog(ui.load_preset, ""); break;
    case Action::save_preset: open_dialog(ui.save_preset, "preset.json"); break;
    case Action::screenshot: open_dialog(ui.screenshot, "cvtmesh.png"); break;
    case Action::quit: ui.quit = true; break;
    case Action::run_all: if (can_run) s.run_all(); break;
    case Action::rerun_stale: if (can_run) s.rerun_stale(); break;
    case Action::run_next_stage: if (can_run) s.run_next_stage(); break;
    case Action::lloyd_step: if (can_run) s.step_lloyd(1); break;
    case Action::lloyd_10: if (can_run) s.step_lloyd(10); break;
    case Action::lloyd_converge: if (can_run) s.step_lloyd(-1); break;
    case Action::optimize_pass: if (can_run) s.step_optimization(1); break;
    case Action::optimize_to_end: if (can_run) s.step_optimization(-1); break;
    case Action::cancel: s.cancel(); break;
    case Action::cycle_view:
      v.mode = v.mode == ViewMode::split    ? ViewMode::view3d
               : v.mode == ViewMode::view3d ? ViewMode::slice
                                            : ViewMode::split;
      ui.fit_slice = true;
      break;
    case Action::sagittal: v.slice_axis = 0, v.slice_index = -1; break;
    case Action::coronal: v.slice_axis = 1, v.slice_index = -1; break;
    case Action::axial: v.slice_axis = 2, v.slice_index = -1; break;
    case Action::slice_up: step_slice(1); break;
    case Action::slice_down: step_slice(-1); break;
    case Action::slice_up_10: step_slice(10); break;
    case Action::slice_down_10: step_slice(-10); break;
    case Action::fit_views: ui.fit_3d = ui.fit_slice = true; break;
    case Action::toggle_clip: v.clip_enabled = !v.clip_enabled; break;
    case Action::flip_clip: v.clip_flip = !v.clip_flip; break;
    case Action::toggle_help: ui.show_help = !ui.show_help; break;
    case Action::toggle_panels: {
      const bool any = ui.show_pipeline || ui.show_quality || ui.show_view;
      ui.show_pipeline = ui.show_quality = ui.show_view = !any;
      ui.fit_slice = true;
      break;
    }
  }
}

FolderListing list_folder(const std::string& folder, const std::vector<std::string>& extensions) {
  namespace fs = std::filesystem;
  auto lower = [](std::string t) {
    std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
    return t;
  };
  auto matches = [&](const std::string& name) {
    if (extensions.empty()) return true;
    const std::string l = lower(name);
    for (const std::string& e : extensions)
      if (l.size() >= e.size() && l.compare(l.size() - e.size(), e.size(), lower(e)) == 0)
        return true;
    return false;
  };
  FolderListing out;
  std::vector<fs::path> dirs, files;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    std::error_code type_ec;
    if (it->is_directory(type_ec))
      dirs.push_back(it->path());
    else if (matches(name))
      files.push_back(it->path());
  }
  if (ec) out.error = "cannot list " + folder + ": " + ec.message();
  auto by_name = [](const fs::path& a, const fs::path& b) { return a.filename() < b.filename(); };
  std::sort(dirs.begin(), dirs.end(), by_name);
  std::sort(files.begin(), files.end(), by_name);
  for (const auto& d : dirs) out.folders.push_back(d.string());
  for (const auto& f : files) out.files.push_back(f.string());
  return out;
}

const std::vector<std::string>& image_extensions() {
  static const std::vector<std::string> list{".nii", ".nii.gz", ".nrrd", ".nhdr",
                                             ".mha", ".mhd",    ".inr",  ".inr.gz"};
  return list;
}

void confirm_dialog(Dialog dialog, Session& s, UiState& ui) {
  FileDialog& d = dialog == Dialog::open_image    ? ui.open_image
                  : dialog == Dialog::export_mesh ? ui.export_mesh
                  : dialog == Dialog::load_preset ? ui.load_preset
                  : dialog == Dialog::save_preset ? ui.save_preset
                                                  : ui.screenshot;
  if (d.path.empty()) return;
  d.open = false;
  switch (dialog) {
    case Dialog::open_image: s.open_image(d.path); break;
    case Dialog::export_mesh: s.export_mesh(d.path); break;
    case Dialog::load_preset:
      if (s.load_preset(d.path)) s.parameters_edited(ui.now_s);
      break;
    case Dialog::save_preset: s.save_preset(d.path); break;
    case Dialog::screenshot:
      ui.screenshot_request =
          ScreenshotRequest{d.path, ui.screenshot_scale, ui.screenshot_transparent};
      break;
  }
}

void open_dropped(Session& s, std::vector<std::string>& paths) {
  if (paths.empty()) return;
  s.open_image(paths.front());
  if (paths.size() > 1)
    s.messages.push_back({false, std::to_string(paths.size()) +
                                     " files dropped: opened the first, " + paths.front()});
  paths.clear();
}

void start_session(Session& s, const StartRequest& r) {
  if (r.image.empty()) return;
  s.open_image(r.image);
  if (r.optimize_passes != 0) {
    if (r.run_all || r.run_through) s.run_through(Stage::shallow);
    s.step_optimization(r.optimize_passes);
    if (r.run_all) s.run_all();
  } else if (r.run_all) {
    s.run_all();
  } else if (r.run_through) {
    s.run_through(*r.run_through);
  }
}

}  // namespace cvt::gui
