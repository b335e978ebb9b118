// File dialogs as ImGui windows: a path field over a listing of one folder (sub-folders first,
// then files with a matching extension). Open image, export mesh, load/save preset, screenshot.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <filesystem>

#include "input_actions.h"
#include "io/mesh_io.h"
#include "ui.h"

namespace cvt::gui {
namespace {

namespace fs = std::filesystem;

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
  const FolderListing listing = list_folder(d.folder, extensions);
  if (!listing.error.empty()) ImGui::TextDisabled("%s", listing.error.c_str());
  std::string enter;
  for (const std::string& dir : listing.folders) {
    const std::string label = fs::path(dir).filename().string() + "/";
    if (ImGui::Selectable(label.c_str(), d.path == dir, ImGuiSelectableFlags_AllowDoubleClick)) {
      d.path = dir;
      if (ImGui::IsMouseDoubleClicked(0)) enter = dir;
    }
  }
  for (const std::string& file : listing.files) {
    const std::string label = fs::path(file).filename().string();
    if (ImGui::Selectable(label.c_str(), d.path == file, ImGuiSelectableFlags_AllowDoubleClick)) {
      d.path = file;
      if (ImGui::IsMouseDoubleClicked(0)) confirmed = true;
    }
  }
  ImGui::EndChild();
  if (!enter.empty()) d.folder = enter;
  if (ImGui::Button(confirm)) confirmed = true;
  ImGui::SameLine();
  if (ImGui::Button("Close")) d.open = false;
  ImGui::End();
  return confirmed && !d.path.empty();
}

}  // namespace

void draw_file_dialogs(UiContext& ctx) {
  Session& s = ctx.session;
  UiState& ui = ctx.ui;
  if (file_dialog("Open image", ui.open_image, "Open", image_extensions()))
    confirm_dialog(Dialog::open_image, s, ui);
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
    confirm_dialog(Dialog::export_mesh, s, ui);
  if (file_dialog("Load preset", ui.load_preset, "Load", {".json"}))
    confirm_dialog(Dialog::load_preset, s, ui);
  if (file_dialog("Save preset", ui.save_preset, "Save", {".json"}))
    confirm_dialog(Dialog::save_preset, s, ui);
  if (ui.screenshot.open) {
    ImGui::SetNextWindowSize(ImVec2(560, 440), ImGuiCond_FirstUseEver);
    if (ImGui::Begin("Screenshot", &ui.screenshot.open)) {
      ImGui::SliderInt("scale (x window size)", &ui.screenshot_scale, 1, 4);
      ImGui::Checkbox("transparent background", &ui.screenshot_transparent);
    }
    ImGui::End();
  }
  if (file_dialog("Screenshot", ui.screenshot, "Save PNG", {".png"}))
    confirm_dialog(Dialog::screenshot, s, ui);
}

}  // namespace cvt::gui
