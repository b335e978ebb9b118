// The two views' GPU side: each keeps the buffers of what it shows and draws them into the
// current viewport. What to show is decided elsewhere (GL-free builders); these only upload
// and draw. Need a current OpenGL 3.3 core context.
#pragma once

#include <array>
#include <glm/glm.hpp>
#include <memory>
#include <vector>

#include "camera.h"
#include "gl_objects.h"
#include "mesh_geometry.h"
#include "shader_program.h"
#include "slice_image.h"

namespace cvt::render {

// The three programs every view uses (compiled once per context).
struct Programs {
  Programs();
  ShaderProgram mesh{"mesh.vert.glsl", "mesh.frag.glsl"};
  ShaderProgram points{"points.vert.glsl", "points.frag.glsl"};
  ShaderProgram slice{"slice.vert.glsl", "slice.frag.glsl"};
};

struct View3DStyle {
  bool show_surface = true;  // mesh faces (or the object surface before a mesh exists)
  bool show_points = true;
  bool show_slice_plane = false;
  bool edges = true;  // triangle edges on the mesh faces
  float point_size_px = 5.0f;
  float pixel_scale = 1.0f;   // screenshot scale: multiplies sizes given in pixels
  float ghost_alpha = 0.15f;  // the visible faces while tets are highlighted
  float slice_plane_alpha = 0.85f;
  bool clip_enabled = false;   // clips the non-tet geometry (object surface, points)
  glm::vec4 clip_plane{0.0f};  // (n, d): dot(n, p) + d > 0 is removed
};

class View3D {
 public:
  explicit View3D(std::shared_ptr<Programs> programs) : programs_(std::move(programs)) {}
  void set_mesh(const MeshSoups& soups);
  void set_object_surface(const std::vector<ColoredVertex>& soup);
  void set_points(const std::vector<ColoredVertex>& points);
  // The slice image placed in the scene on the quad `corners` (world mm, in the order
  // (u0,v0), (u1,v0), (u1,v1), (u0,v1)).
  void set_slice_plane(const SliceImage& image, const std::array<glm::vec3, 4>& corners);
  bool has_mesh() const { return solid_.count() + ghost_.count() > 0; }
  // Draws into the current viewport (width × height pixels); does not clear.
  void draw(const OrbitCamera& camera, int width, int height, const View3DStyle& style);

 private:
  std::shared_ptr<Programs> programs_;
  ColoredVertexArray solid_, ghost_, object_surface_, points_;
  Texture2D slice_texture_;
  GlName<delete_vertex_array> slice_vao_;
  GlName<delete_buffer> slice_vbo_;
};

class SliceView2D {
 public:
  explicit SliceView2D(std::shared_ptr<Programs> programs) : programs_(std::move(programs)) {}
  void set_image(const SliceImage& image);
  void set_points(const std::vector<SlicePoint>& points);
  float width_mm() const { return width_mm_; }
  float height_mm() const { return height_mm_; }
  // Draws into the current viewport (width × height pixels); does not clear.
  void draw(const SliceViewTransform& transform, int width, int height, float point_size_px);

 private:
  std::shared_ptr<Programs> programs_;
  Texture2D texture_;
  GlName<delete_vertex_array> quad_vao_;
  GlName<delete_buffer> quad_vbo_;
  ColoredVertexArray points_;
  float width_mm_ = 0, height_mm_ = 0;
};

// Uploads a textured quad: 4 corners (xyz) with uv (0,0), (1,0), (1,1), (0,1), as a fan.
void upload_textured_quad(GlName<delete_vertex_array>& vao, GlName<delete_buffer>& vbo,
                          const std::array<glm::vec3, 4>& corners);

}  // namespace cvt::render
