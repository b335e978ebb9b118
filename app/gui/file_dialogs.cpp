// File dialogs as ImGui windows: a path field over a listing of one folder (sub-folders first,
// then files with a matching extension). Open image, export mesh, load/save preset, screenshot.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <filesystem>

#include "mesh_io.h"
#include "ui.h"

namespace cvt::gui {
namespace {

namespace fs = std::filesystem;

bool has_extension(const std::string& name, const std::vector<std::string>& extensions) {
  if (extensions.empty()) return true;
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  for (const std::string& e : extensions)
    if (lower.size() >= e.size() && lower.compare(lower.size() - e.size(), e.size(), e) == 0)
      return true;
  return false;
}

// Draws the dialog; returns true when the user confirms `d.path` (then closes it).
bool file_dialog(const char* title, FileDialog& d, const char* confirm,
                 const std::vector<std::string>& extensions) {
  if (!d.open) return false;
  ImGui::SetNextWindowSize(ImVec2(560, 440), ImGuiCond_FirstUseEver);
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(0.5f * display.x, 0.5f * display.y), ImGuiCond_FirstUseEver,
                          ImVec2(0.5f, 0.5f));
  bool confirmed = false;
  if (!ImGui::Begin(title, &d.open)) {
    ImGui::End();
    return false;
  }
  ImGui::SetNextItemWidth(-70);
  if (ImGui::InputText("path", &d.path, ImGuiInputTextFlags_EnterReturnsTrue)) confirmed = true;
  ImGui::SetNextItemWidth(-70);
  ImGui::InputText("folder", &d.folder);
  if (ImGui::Button("Up")) d.folder = fs::path(d.folder).parent_path().string();
  ImGui::SameLine();
  if (ImGui::Button("This folder")) d.path = d.folder;
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Choose the folder (DICOM series, TIFF/PNG slices)");
  ImGui::BeginChild("listing", ImVec2(0, -ImGui::GetFrameHeightWithSpacing() * 1.3f), true);
  std::vector<fs::directory_entry> dirs, files;
  std::error_code ec;
  for (fs::directory_iterator it(d.folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    if (it->is_directory(ec))
      dirs.push_back(*it);
    else if (has_extension(name, extensions))
      files.push_back(*it);
  }
  if (ec) ImGui::TextDisabled("cannot list %s: %s", d.folder.c_str(), ec.message().c_str());
  auto by_name = [](const auto& a, const auto& b) {
    return a.path().filename() < b.path().filename();
  };
  std::sort(dirs.begin(), dirs.end(), by_name);
  std::sort(files.begin(), files.end(), by_name);
  std::string enter;
  for (const auto& e : dirs) {
    const std::string label = e.path().filename().string() + "/";
    if (ImGui::Selectable(label.c_str(), d.path == e.path().string(),
                          ImGuiSelectableFlags_AllowDoubleClick)) {
      d.path = e.path().string();
      if (ImGui::IsMouseDoubleClicked(0)) enter = e.path().string();
    }
  }
  for (const auto& e : files) {
    const std::string label = e.path().filename().string();
    if (ImGui::Selectable(label.c_str(), d.path == e.path().string(),
                          ImGuiSelectableFlags_AllowDoubleClick)) {
      d.path = e.path().string();
      if (ImGui::IsMouseDoubleClicked(0)) confirmed = true;
    }
  }
  ImGui::EndChild();
  if (!enter.empty()) d.folder = enter;
  if (ImGui::Button(confirm)) confirmed = true;
  ImGui::SameLine();
  if (ImGui::Button("Close")) d.open = false;
  ImGui::End();
  if (confirmed && !d.path.empty()) {
    d.open = false;
    return true;
  }
  return false;
}

const std::vector<std::string> kImageExtensions{".nii", ".nii.gz", ".nrrd", ".nhdr",
                                                ".mha", ".mhd",    ".inr",  ".inr.gz"};

}  // namespace

void draw_file_dialogs(UiContext& ctx) {
  Session& s = ctx.session;
  UiState& ui = ctx.ui;
  if (file_dialog("Open image", ui.open_image, "Open", kImageExtensions))
    s.open_image(ui.open_image.path);
  if (ui.export_mesh.open) {
    // The format follows the extension; the buttons swap it.
    ImGui::SetNextWindowSize(ImVec2(560, 440), ImGuiCond_FirstUseEver);
    if (ImGui::Begin("Export mesh", &ui.export_mesh.open)) {
      ImGui::TextUnformatted("format:");
      for (const std::string& ext : mesh_write_extensions()) {
        ImGui::SameLine();
        if (ImGui::SmallButton(ext.c_str()))
          ui.export_mesh.path = fs::path(ui.export_mesh.path).replace_extension(ext).string();
      }
    }
    ImGui::End();
  }
  if (file_dialog("Export mesh", ui.export_mesh, "Export", mesh_write_extensions()))
    s.export_mesh(ui.export_mesh.path);
  if (file_dialog("Load preset", ui.load_preset, "Load", {".json"})) {
    if (s.load_preset(ui.load_preset.path)) s.parameters_edited(ui.now_s);
  }
  if (file_dialog("Save preset", ui.save_preset, "Save", {".json"}))
    s.save_preset(ui.save_preset.path);
  if (ui.screenshot.open) {
    ImGui::SetNextWindowSize(ImVec2(560, 440), ImGuiCond_FirstUseEver);
    if (ImGui::Begin("Screenshot", &ui.screenshot.open)) {
      ImGui::SliderInt("scale (x window size)", &ui.screenshot_scale, 1, 4);
      ImGui::Checkbox("transparent background", &ui.screenshot_transparent);
    }
    ImGui::End();
  }
  if (file_dialog("Screenshot", ui.screenshot, "Save PNG", {".png"}))
    ui.screenshot_request =
        ScreenshotRequest{ui.screenshot.path, ui.screenshot_scale, ui.screenshot_transparent};
}

}  // namespace cvt::gui
