// Small owning wrappers of OpenGL objects (buffers, vertex arrays, textures, framebuffers):
// created on first use, deleted with the wrapper, movable, not copyable. Need a current context.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "gl.h"

namespace cvt::render {

// An owned GL name with its delete function.
template <void (*Delete)(GLuint)>
class GlName {
 public:
  GlName() = default;
  explicit GlName(GLuint id) : id_(id) {}
  ~GlName() { reset(); }
  GlName(GlName&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  GlName& operator=(GlName&& o) noexcept {
    if (this != &o) reset(), id_ = std::exchange(o.id_, 0);
    return *this;
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  GLuint get() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  void reset() {
    if (id_) Delete(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

void delete_buffer(GLuint id);
void delete_vertex_array(GLuint id);
void delete_texture(GLuint id);
void delete_framebuffer(GLuint id);
void delete_renderbuffer(GLuint id);

// A vertex array with one interleaved buffer of position (3 floats) + RGBA8 colour: the
// ColoredVertex layout every soup and point list uses.
class ColoredVertexArray {
 public:
  // Replaces the contents (16-byte vertices).
  void upload(const void* vertices, std::size_t count);
  void draw(GLenum mode) const;  // GL_TRIANGLES or GL_POINTS
  std::size_t count() const { return count_; }

 private:
  GlName<delete_vertex_array> vao_;
  GlName<delete_buffer> vbo_;
  std::size_t count_ = 0;
};

// An RGBA8 texture, nearest filtering, clamped.
class Texture2D {
 public:
  void upload(int width, int height, const void* rgba);
  void bind(int unit) const;
  int width() const { return width_; }
  int height() const { return height_; }
  explicit operator bool() const { return bool(id_); }

 private:
  GlName<delete_texture> id_;
  int width_ = 0, height_ = 0;
};

// An off-screen colour (RGBA8) + depth target, for screenshots at any size and for keeping the
// views' picture.
class Framebuffer {
 public:
  // (Re)allocates when the size changes; throws std::runtime_error when incomplete.
  void ensure(int width, int height);
  void bind() const;
  // RGBA rows top first (GL reads bottom first, so rows are flipped).
  std::vector<std::uint8_t> read_rgba() const;
  // Copies the colour into the window's framebuffer (same size), which is then bound.
  void blit_to_window() const;
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  GlName<delete_framebuffer> fbo_;
  GlName<delete_texture> color_;
  GlName<delete_renderbuffer> depth_;
  int width_ = 0, height_ = 0;
};

}  // namespace cvt::render
