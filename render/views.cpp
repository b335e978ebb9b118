#include "views.h"

#include <glm/gtc/matrix_transform.hpp>

namespace cvt::render {

Programs::Programs() = default;

void upload_textured_quad(GlName<delete_vertex_array>& vao, GlName<delete_buffer>& vbo,
                          const std::array<glm::vec3, 4>& corners) {
  if (!vao) {
    GLuint a = 0, b = 0;
    glGenVertexArrays(1, &a);
    glGenBuffers(1, &b);
    vao = GlName<delete_vertex_array>(a);
    vbo = GlName<delete_buffer>(b);
    glBindVertexArray(a);
    glBindBuffer(GL_ARRAY_BUFFER, b);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 20, reinterpret_cast<void*>(0));
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, 20, reinterpret_cast<void*>(12));
    glBindVertexArray(0);
  }
  const float uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  float data[4 * 5];
  for (int i = 0; i < 4; ++i) {
    data[5 * i + 0] = corners[i].x;
    data[5 * i + 1] = corners[i].y;
    data[5 * i + 2] = corners[i].z;
    data[5 * i + 3] = uv[i][0];
    data[5 * i + 4] = uv[i][1];
  }
  glBindBuffer(GL_ARRAY_BUFFER, vbo.get());
  glBufferData(GL_ARRAY_BUFFER, sizeof data, data, GL_DYNAMIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void View3D::set_mesh(const MeshSoups& soups) {
  solid_.upload(soups.solid.data(), soups.solid.size());
  ghost_.upload(soups.ghost.data(), soups.ghost.size());
}

void View3D::set_object_surface(const std::vector<ColoredVertex>& soup) {
  object_surface_.upload(soup.data(), soup.size());
}

void View3D::set_points(const std::vector<ColoredVertex>& points) {
  points_.upload(points.data(), points.size());
}

void View3D::set_slice_plane(const SliceImage& image, const std::array<glm::vec3, 4>& corners) {
  slice_texture_.upload(image.width, image.height, image.pixels.data());
  upload_textured_quad(slice_vao_, slice_vbo_, corners);
}

void View3D::draw(const OrbitCamera& camera, int width, int height, const View3DStyle& style) {
  const glm::mat4 view = camera.view();
  const glm::mat4 projection = camera.projection(float(width) / float(std::max(height, 1)));
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glEnable(GL_CLIP_DISTANCE0);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);

  ShaderProgram& mesh = programs_->mesh;
  mesh.use();
  mesh.set("u_view", view);
  mesh.set("u_projection", projection);
  mesh.set("u_edge_width", 1.0f * style.pixel_scale);
  mesh.set("u_alpha", 1.0f);
  // Both soups are closed and outward oriented (counter-clockwise seen from outside): culling
  // the back faces halves the fragments a software rasteriser shades.
  glEnable(GL_CULL_FACE);
  glCullFace(GL_BACK);
  if (style.show_surface) {
    if (solid_.count() + ghost_.count() > 0) {
      // Whole tets: the clip already chose them, so no fragment clipping.
      mesh.set("u_clip_enabled", false);
      mesh.set("u_edges", style.edges);
      solid_.draw(GL_TRIANGLES);
    } else {
      mesh.set("u_clip_enabled", style.clip_enabled);
      mesh.set("u_clip_plane", style.clip_plane);
      mesh.set("u_edges", false);
      // A clipped surface shows its inside through the cut: keep the back faces then.
      if (style.clip_enabled) glDisable(GL_CULL_FACE);
      object_surface_.draw(GL_TRIANGLES);
    }
  }
  glDisable(GL_CULL_FACE);
  if (style.show_points && points_.count()) {
    ShaderProgram& p = programs_->points;
    glEnable(GL_PROGRAM_POINT_SIZE);
    p.use();
    p.set("u_view", view);
    p.set("u_projection", projection);
    p.set("u_point_size", style.point_size_px * style.pixel_scale);
    p.set("u_clip_enabled", style.clip_enabled);
    p.set("u_clip_plane", style.clip_plane);
    points_.draw(GL_POINTS);
  }
  if (style.show_slice_plane && slice_texture_) {
    ShaderProgram& s = programs_->slice;
    s.use();
    s.set("u_view", view);
    s.set("u_projection", projection);
    s.set("u_alpha", style.slice_plane_alpha);
    s.set("u_texture", 0);
    slice_texture_.bind(0);
    glBindVertexArray(slice_vao_.get());
    glDrawArrays(GL_TRIANGLE_FAN, 0, 4);
    glBindVertexArray(0);
  }
  // Translucent faces last, without depth writes, so the highlighted tets show through.
  if (style.show_surface && ghost_.count()) {
    mesh.use();
    mesh.set("u_clip_enabled", false);
    mesh.set("u_edges", false);
    mesh.set("u_alpha", style.ghost_alpha);
    glDepthMask(GL_FALSE);
    ghost_.draw(GL_TRIANGLES);
    glDepthMask(GL_TRUE);
  }
  glDisable(GL_CLIP_DISTANCE0);
  glDisable(GL_DEPTH_TEST);
  glUseProgram(0);
}

void SliceView2D::set_image(const SliceImage& image) {
  texture_.upload(image.width, image.height, image.pixels.data());
  // Voxel t covers [t − ½, t + ½] voxel spacings (upsample pixels each), so voxel centres sit
  // at t · spacing, where the points are placed.
  const float su = float(image.pixel_mm[0]), sv = float(image.pixel_mm[1]);
  const float half = 0.5f * float(image.upsample);
  const float u0 = -half * su, v0 = -half * sv;
  const float u1 = (float(image.width) - half) * su, v1 = (float(image.height) - half) * sv;
  upload_textured_quad(
      quad_vao_, quad_vbo_,
      {glm::vec3(u0, v0, 0), glm::vec3(u1, v0, 0), glm::vec3(u1, v1, 0), glm::vec3(u0, v1, 0)});
  width_mm_ = float(image.width) * su;
  height_mm_ = float(image.height) * sv;
}

void SliceView2D::set_points(const std::vector<SlicePoint>& points) {
  std::vector<ColoredVertex> vertices;
  vertices.reserve(points.size());
  for (const SlicePoint& p : points) vertices.push_back({{p.u_mm, p.v_mm, 0.0f}, p.color});
  points_.upload(vertices.data(), vertices.size());
}

void SliceView2D::draw(const SliceViewTransform& transform, int width, int height,
                       float point_size_px) {
  if (!texture_) return;
  const glm::mat4 projection = transform.projection(float(width), float(height));
  const glm::mat4 identity(1.0f);
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  ShaderProgram& s = programs_->slice;
  s.use();
  s.set("u_view", identity);
  s.set("u_projection", projection);
  s.set("u_alpha", 1.0f);
  s.set("u_texture", 0);
  texture_.bind(0);
  glBindVertexArray(quad_vao_.get());
  glDrawArrays(GL_TRIANGLE_FAN, 0, 4);
  glBindVertexArray(0);
  if (points_.count()) {
    ShaderProgram& p = programs_->points;
    glEnable(GL_PROGRAM_POINT_SIZE);
    p.use();
    p.set("u_view", identity);
    p.set("u_projection", projection);
    p.set("u_point_size", point_size_px);
    p.set("u_clip_enabled", false);
    points_.draw(GL_POINTS);
  }
  glUseProgram(0);
}

}  // namespace cvt::render
