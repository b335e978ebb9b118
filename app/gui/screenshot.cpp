#include "screenshot.h"

#include <imgui.h>
#include <imgui_impl_opengl3.h>
#include <imgui_internal.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "png_io.h"

namespace cvt::gui {

void take_screenshot(const ScreenshotRequest& request, SceneRenderer& renderer,
                     const ViewSettings& view, const Rect& area, int window_w, int window_h,
                     render::Framebuffer& framebuffer) {
  const int scale = std::clamp(request.scale, 1, 8);
  // The picture covers `shot` (window units); the views keep their place inside it.
  const Rect shot = request.include_ui ? Rect{0, 0, float(window_w), float(window_h)} : area;
  const int w = int(std::lround(shot.w)) * scale, h = int(std::lround(shot.h)) * scale;
  framebuffer.ensure(w, h);
  framebuffer.bind();
  ViewRects rects = view_rects(view.mode, area);
  for (Rect* r : {&rects.view3d, &rects.slice}) r->x -= shot.x, r->y -= shot.y;
  renderer.draw(view, rects, {w, h, float(scale)}, request.transparent);

  // The legend windows of this frame, drawn again into the framebuffer: their draw lists stay
  // valid until the next ImGui::NewFrame, and the backend scales them by FramebufferScale.
  ImGuiContext& g = *ImGui::GetCurrentContext();
  std::vector<ImDrawList*> lists;
  int vertices = 0, indices = 0;
  for (ImGuiWindow* window : g.Windows)
    if (window->Active && !window->Hidden && std::strncmp(window->Name, "legend", 6) == 0 &&
        window->DrawList && !window->DrawList->CmdBuffer.empty()) {
      lists.push_back(window->DrawList);
      vertices += window->DrawList->VtxBuffer.Size;
      indices += window->DrawList->IdxBuffer.Size;
    }
  if (request.include_ui) {
    ImDrawData data = *ImGui::GetDrawData();
    data.FramebufferScale = ImVec2(float(scale), float(scale));
    ImGui_ImplOpenGL3_RenderDrawData(&data);
  } else if (!lists.empty()) {
    ImDrawData data;
    data.Valid = true;
    data.CmdLists = lists.data();
    data.CmdListsCount = int(lists.size());
    data.TotalVtxCount = vertices;
    data.TotalIdxCount = indices;
    data.DisplayPos = ImVec2(shot.x, shot.y);
    data.DisplaySize = ImVec2(shot.w, shot.h);
    data.FramebufferScale = ImVec2(float(scale), float(scale));
    ImGui_ImplOpenGL3_RenderDrawData(&data);
  }
  const std::vector<std::uint8_t> pixels = framebuffer.read_rgba();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  render::write_png(request.path, w, h, pixels, request.transparent);
}

}  // namespace cvt::gui
