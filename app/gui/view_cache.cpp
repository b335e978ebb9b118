#include "view_cache.h"

namespace cvt::gui {

void ViewCache::draw(SceneRenderer& renderer, const std::shared_ptr<const render::SceneData>& scene,
                     const std::shared_ptr<const render::LloydState>& lloyd,
                     const ViewSettings& view, const ViewRects& rects, const DrawTarget& target,
                     bool reuse) {
  const Key key{renderer.revision(), scene.get(), lloyd.get(), view, rects, target.width,
                target.height};
  if (!reuse) {
    kept_.reset();
    renderer.draw(view, rects, target, false);
    ++drawn;
    return;
  }
  if (kept_ == key) {
    picture_.blit_to_window();
    ++reshown;
    return;
  }
  picture_.ensure(target.width, target.height);
  picture_.bind();
  renderer.draw(view, rects, target, false);
  picture_.blit_to_window();
  kept_ = key;
  ++drawn;
}

}  // namespace cvt::gui
