// The app side of drawing: keeps the two views' GPU buffers in step with the latest snapshot and
// the view settings (rebuilding only what changed), owns the cameras, and draws the views into
// their rectangles, on screen or into a screenshot framebuffer at any scale.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <tuple>
#include <vector>

#include "camera.h"
#include "scene_data.h"
#include "slice_composer.h"
#include "view_settings.h"
#include "views.h"

namespace cvt::gui {

struct DrawTarget {
  int width = 0, height = 0;  // framebuffer pixels
  float scale = 1.0f;         // framebuffer pixels per window unit (screenshots: 1–4)
};

class SceneRenderer {
 public:
  SceneRenderer();  // needs a current GL context

  // Rebuilds the buffers the snapshot or the settings changed. `rects`: where the views are,
  // for fitting the slice when a new one arrives.
  void sync(const std::shared_ptr<const render::SceneData>& scene,
            const std::shared_ptr<const render::LloydState>& lloyd, const ViewSettings& view,
            const ViewRects& rects);
  // True while a slice picture is being composed (scripted runs wait for it).
  bool busy() const { return composer_.busy(); }
  // Counts the changes to what draw() shows that are not in its arguments: a buffer rebuilt,
  // a slice picture uploaded, a camera fitted (the mouse moves the cameras only on input).
  std::uint64_t revision() const { return revision_; }
  // Clears the bound framebuffer and draws the views into `rects` (window units relative to
  // the framebuffer's top-left corner, scaled by target.scale).
  void draw(const ViewSettings& view, const ViewRects& rects, const DrawTarget& target,
            bool transparent_background);

  void fit_3d();
  void fit_slice(const Rect& rect);

  render::OrbitCamera camera;
  render::SliceViewTransform slice_transform;
  // What is drawn, for the status line and the legends.
  std::size_t kept_tets = 0, cut_faces = 0, highlighted_tets = 0, slice_points = 0;
  int slice_index = 0;
  bool has_mesh = false, has_slice = false;

 private:
  void rebuild_mesh(const render::SceneData& scene, const ViewSettings& view);
  void rebuild_points(const render::SceneData& scene, const render::LloydState* lloyd,
                      const ViewSettings& view);
  void request_slice(const std::shared_ptr<const render::SceneData>& scene,
                     const std::shared_ptr<const render::LloydState>& lloyd,
                     const ViewSettings& view);
  void upload_slice(render::SliceView&& view);
  const render::ClipPlane* clip_plane(const ViewSettings& view);

  std::uint64_t revision_ = 0;
  std::shared_ptr<render::Programs> programs_;
  render::View3D view3d_;
  render::SliceView2D slice_view_;
  render::ClipPlane clip_{};
  Vec3 box_lo_{}, box_hi_{};  // what the 3D view fits and the clip position is relative to
  bool have_box_ = false;
  // What each buffer was built from (the generations of the snapshot's parts, and settings); a
  // buffer is rebuilt when its key changes.
  using Part = std::uint64_t;  // a PartGenerations entry, or LloydState::generation
  using ClipKey = std::tuple<bool, int, double, bool>;
  using MeshKey = std::tuple<Part, ClipKey, std::optional<Measure>, bool, render::TetSelection>;
  using PointsKey =
      std::tuple<Part, Part, Part, Part, render::Overlays, ClipKey, std::pair<bool, bool>>;
  using SliceKey = std::tuple<Part, Part, Part, Part, Part, Part, int, int, render::Overlays,
                              std::optional<render::WindowLevel>>;
  std::optional<MeshKey> mesh_key_;
  std::optional<PointsKey> points_key_;
  std::optional<SliceKey> slice_key_;
  Part surface_key_ = 0, fitted_image_ = 0;
  bool fitted_to_mesh_ = false, fitted_to_volume_ = false;
  std::tuple<std::uint64_t, int> slice_fitted_{0, -1};
  Rect slice_rect_;  // where the slice view is, for fitting a picture when it arrives
  render::AsyncSliceComposer composer_;
  glm::vec4 clear_color_{0.13f, 0.14f, 0.17f, 1.0f};
  float aspect_3d_ = 1.0f;  // of the 3D view's rectangle, for fitting
};

}  // namespace cvt::gui
