#include "scene_renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "gl.h"

namespace cvt::gui {
namespace {

glm::vec3 to_glm(const Vec3& v) {
  return {float(v.x), float(v.y), float(v.z)};
}

// World bounding box of a grid's voxel centres (all eight corners, whatever the direction).
void grid_box(const Grid& g, Vec3& lo, Vec3& hi) {
  const double inf = std::numeric_limits<double>::infinity();
  lo = {inf, inf, inf};
  hi = {-inf, -inf, -inf};
  for (int c = 0; c < 8; ++c) {
    const Vec3 idx{(c & 1) ? g.dims[0] - 1.0 : 0.0, (c & 2) ? g.dims[1] - 1.0 : 0.0,
                   (c & 4) ? g.dims[2] - 1.0 : 0.0};
    const Vec3 w = g.index_to_world(idx);
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], w[a]), hi[a] = std::max(hi[a], w[a]);
  }
}

// GL viewport of a window rect (origin top-left) in a framebuffer `scale` times the window.
void set_viewport(const Rect& r, const DrawTarget& t) {
  const int x = int(std::lround(r.x * t.scale)), w = int(std::lround(r.w * t.scale));
  const int h = int(std::lround(r.h * t.scale));
  const int y = t.height - int(std::lround(r.y * t.scale)) - h;
  glViewport(x, y, w, h);
  glScissor(x, y, w, h);
}

}  // namespace

SceneRenderer::SceneRenderer()
    : programs_(std::make_shared<render::Programs>()), view3d_(programs_), slice_view_(programs_) {}

const render::ClipPlane* SceneRenderer::clip_plane(const ViewSettings& view) {
  if (!view.clip_enabled || !have_box_) return nullptr;
  clip_ =
      render::axis_clip_plane(box_lo_, box_hi_, view.clip_axis, view.clip_position, view.clip_flip);
  return &clip_;
}

void SceneRenderer::sync(const std::shared_ptr<const render::SceneData>& scene_ptr,
                         const std::shared_ptr<const render::LloydState>& lloyd,
                         const ViewSettings& view, const ViewRects& rects) {
  if (!rects.view3d.empty()) aspect_3d_ = rects.view3d.w / rects.view3d.h;
  slice_rect_ = rects.slice;
  if (auto picture = composer_.take()) upload_slice(std::move(*picture));
  if (!scene_ptr || !scene_ptr->image) return;
  const render::SceneData* scene = scene_ptr.get();
  const render::PartGenerations& built = scene->generations;
  const std::uint64_t lloyd_generation = lloyd ? lloyd->generation : 0;
  // The box the 3D view fits and the clip is placed in: the mesh, else the object's crop,
  // else the image. Refit when a better one first arrives for this image.
  if (built.image != fitted_image_)
    fitted_image_ = built.image, fitted_to_mesh_ = fitted_to_volume_ = false;
  bool refit = false;
  if (scene->mesh) {
    box_lo_ = scene->mesh->lo, box_hi_ = scene->mesh->hi;
    refit = !fitted_to_mesh_;
    fitted_to_mesh_ = fitted_to_volume_ = true;
  } else if (scene->volumes) {
    grid_box(scene->volumes->grid, box_lo_, box_hi_);
    refit = !fitted_to_volume_;
    fitted_to_volume_ = true;
  } else {
    grid_box(scene->image->grid(), box_lo_, box_hi_);
    refit = !have_box_;
  }
  have_box_ = true;
  if (refit) fit_3d();

  const ClipKey clip_key{view.clip_enabled, view.clip_axis, view.clip_position, view.clip_flip};
  MeshKey mesh_key{built.mesh, clip_key, view.color_by, view.color_boundary, view.highlight};
  if (mesh_key != mesh_key_) {
    mesh_key_ = std::move(mesh_key);
    rebuild_mesh(*scene, view);
    ++revision_;
  }
  if (built.volumes != surface_key_) {
    surface_key_ = built.volumes;
    std::vector<render::ColoredVertex> soup;
    if (scene->volumes)
      render::append_surface(scene->volumes->object_surface, render::MeshColoring{}.surface, soup);
    view3d_.set_object_surface(soup);
    ++revision_;
  }
  PointsKey points_key{built.surface,
                       lloyd_generation,
                       built.shallow,
                       built.mesh,
                       view.overlays,
                       clip_key,
                       std::pair(view.show_surface, view.show_points)};
  if (points_key != points_key_) {
    points_key_ = std::move(points_key);
    rebuild_points(*scene, lloyd.get(), view);
    ++revision_;
  }
  slice_index = effective_slice_index(view, *scene);
  SliceKey slice_key{built.image,      built.volumes, view.overlays.voronoi ? lloyd_generation : 0,
                     built.surface,    built.shallow, built.mesh,
                     view.slice_axis,  slice_index,   view.overlays,
                     view.window_level};
  if (slice_key != slice_key_) {
    slice_key_ = std::move(slice_key);
    request_slice(scene_ptr, lloyd, view);
  }
}

void SceneRenderer::rebuild_mesh(const render::SceneData& scene, const ViewSettings& view) {
  has_mesh = scene.mesh != nullptr;
  render::MeshSoups soups;
  if (scene.mesh) {
    render::MeshColoring coloring;
    coloring.measure = view.color_by;
    coloring.measure_on_boundary = view.color_boundary;
    std::vector<std::uint8_t> highlight;
    if (view.highlight.kind != render::TetSelection::Kind::none)
      highlight =
          render::select_tets(scene.mesh->measures[int(view.highlight.measure)], view.highlight);
    soups = render::build_mesh_soups(*scene.mesh, clip_plane(view), coloring,
                                     highlight.empty() ? nullptr : &highlight);
  }
  kept_tets = soups.kept_tets;
  cut_faces = soups.cut_faces;
  highlighted_tets = soups.highlighted_tets;
  view3d_.set_mesh(soups);
}

void SceneRenderer::rebuild_points(const render::SceneData& scene, const render::LloydState* lloyd,
                                   const ViewSettings& view) {
  std::vector<render::ColoredVertex> points;
  const render::ClipPlane* clip = clip_plane(view);
  const PointsShown shown = points_shown_3d(view, scene.volumes != nullptr, scene.mesh != nullptr);
  if (shown.samples && scene.surface_samples)
    render::append_points(*scene.surface_samples, render::kSampleColor, clip, points);
  if (const std::vector<Vec3>* interior = render::interior_points(scene, lloyd);
      shown.interior && interior)
    render::append_points(*interior, render::kInteriorColor, clip, points);
  if (shown.shallow && scene.shallow)
    render::append_points(scene.shallow->removed_world, render::kShallowColor, clip, points);
  if (shown.poles && scene.mesh)
    render::append_points(scene.mesh->exterior_poles, render::kPoleColor, clip, points);
  view3d_.set_points(points);
}

void SceneRenderer::request_slice(const std::shared_ptr<const render::SceneData>& scene,
                                  const std::shared_ptr<const render::LloydState>& lloyd,
                                  const ViewSettings& view) {
  render::SliceRequest r;
  r.scene = scene;
  r.lloyd = lloyd;
  r.axis = view.slice_axis;
  r.index = slice_index;
  r.overlays = view.overlays;
  r.window_level = view.window_level.value_or(render::default_window_level(scene->value_range));
  composer_.request(std::move(r));
}

void SceneRenderer::upload_slice(render::SliceView&& picture) {
  ++revision_;
  slice_view_.set_image(picture.image);
  slice_view_.set_points(picture.points);
  slice_points = picture.points.size();
  std::array<glm::vec3, 4> corners;
  for (int k = 0; k < 4; ++k) corners[k] = to_glm(picture.plane_corners[k]);
  view3d_.set_slice_plane(picture.image, corners);
  has_slice = true;
  // Fit when the picture changes shape (a new image, another axis).
  const std::tuple<std::uint64_t, int> shape{picture.image_generation, picture.axis};
  if (shape != slice_fitted_) {
    slice_fitted_ = shape;
    fit_slice(slice_rect_);
  }
}

void SceneRenderer::fit_3d() {
  ++revision_;
  if (have_box_) camera.fit(to_glm(box_lo_), to_glm(box_hi_), aspect_3d_);
}

void SceneRenderer::fit_slice(const Rect& rect) {
  ++revision_;
  if (rect.empty() || !has_slice) return;
  slice_transform.fit(slice_view_.width_mm(), slice_view_.height_mm(), rect.w, rect.h);
}

void SceneRenderer::draw(const ViewSettings& view, const ViewRects& rects, const DrawTarget& target,
                         bool transparent_background) {
  glViewport(0, 0, target.width, target.height);
  glDisable(GL_SCISSOR_TEST);
  const glm::vec4 c = clear_color_;
  glClearColor(c.r, c.g, c.b, transparent_background ? 0.0f : 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_SCISSOR_TEST);
  if (!rects.view3d.empty()) {
    set_viewport(rects.view3d, target);
    render::View3DStyle style;
    style.show_surface = view.show_surface;
    style.show_points = view.show_points;
    style.show_slice_plane = view.show_slice_plane;
    style.edges = view.edges;
    style.point_size_px = view.point_size_px;
    style.pixel_scale = target.scale;
    if (const render::ClipPlane* p = clip_plane(view)) {
      style.clip_enabled = true;
      const glm::vec3 n = to_glm(p->normal);
      style.clip_plane = glm::vec4(n, -glm::dot(n, to_glm(p->point)));
    }
    view3d_.draw(camera, int(std::lround(rects.view3d.w * target.scale)),
                 int(std::lround(rects.view3d.h * target.scale)), style);
  }
  if (!rects.slice.empty()) {
    set_viewport(rects.slice, target);
    // The slice transform is in window units; the projection only needs the aspect, so the
    // same transform renders any scale.
    slice_view_.draw(slice_transform, int(std::lround(rects.slice.w)),
                     int(std::lround(rects.slice.h)), view.point_size_px * target.scale);
  }
  glDisable(GL_SCISSOR_TEST);
  glViewport(0, 0, target.width, target.height);
}

}  // namespace cvt::gui
