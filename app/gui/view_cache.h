// The views' last picture, re-shown while a job runs and nothing they draw has changed: on a
// software renderer (Mesa llvmpipe) drawing a brain-size scene costs ~80 ms of CPU a frame,
// taken from the pipeline, though only the progress in the panels moves.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <tuple>

#include "gl_objects.h"
#include "scene_renderer.h"

namespace cvt::gui {

class ViewCache {
 public:
  // Draws the views into the window's framebuffer: the kept picture when `reuse` allows and
  // nothing it depends on changed, else drawn afresh (and kept when `reuse`: a job runs).
  void draw(SceneRenderer& renderer, const std::shared_ptr<const render::SceneData>& scene,
            const std::shared_ptr<const render::LloydState>& lloyd, const ViewSettings& view,
            const ViewRects& rects, const DrawTarget& target, bool reuse);
  // Frames drawn afresh and re-shown since the start.
  std::uint64_t drawn = 0, reshown = 0;

 private:
  using Key = std::tuple<std::uint64_t, std::uint64_t, std::uint64_t, ViewSettings, ViewRects, int,
                         int>;
  render::Framebuffer picture_;
  std::optional<Key> kept_;
  bool broken_ = false;  // the off-screen target could not be made
};

}  // namespace cvt::gui
