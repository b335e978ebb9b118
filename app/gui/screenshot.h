// Screenshots: the views re-rendered into an off-screen framebuffer at K × the window size
// (sizes in pixels scale too), with the legends of this frame drawn over them, saved as PNG.
#pragma once

#include "gl_objects.h"
#include "scene_renderer.h"
#include "ui.h"

namespace cvt::gui {

// Call after ImGui::Render() of the frame whose legends should appear. `area`: the views' area
// (window units); with request.include_ui the whole window (window_w × window_h) is taken.
// Throws InputError when the PNG cannot be written.
void take_screenshot(const ScreenshotRequest& request, SceneRenderer& renderer,
                     const ViewSettings& view, const Rect& area, int window_w, int window_h,
                     render::Framebuffer& framebuffer);

}  // namespace cvt::gui
