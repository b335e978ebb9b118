#include "view_cache.h"

#include <stdexcept>

namespace cvt::gui {

void ViewCache::draw(SceneRenderer& renderer, const std::shared_ptr<const render::SceneData>& scene,
                     const std::shared_ptr<const render::LloydState>& lloyd,
                     const ViewSettings& view, const ViewRects& rects, const DrawTarget& target,
                     bool reuse) {
  // Snapshots and Lloyd states by their numbers, never their addresses (scene_data.h).
  const Key key{renderer.revision(), scene ? scene->generation : 0, lloyd ? lloyd->generation : 0,
                view, rects, target.width, target.height};
  auto draw_afresh = [&] {
    kept_.reset();
    renderer.draw(view, rects, target, false);
    ++drawn;
  };
  if (!reuse || broken_) return draw_afresh();
  if (kept_ == key) {
    picture_.blit_to_window();
    ++reshown;
    return;
  }
  try {
    picture_.ensure(target.width, target.height);
  } catch (const std::runtime_error&) {  // no off-screen target here: always draw afresh
    broken_ = true;
    return draw_afresh();
  }
  picture_.bind();
  renderer.draw(view, rects, target, false);
  picture_.blit_to_window();
  kept_ = key;
  ++drawn;
}

}  // namespace cvt::gui
