// A linked GLSL program built from two embedded shader files, with cached uniform locations.
#pragma once

#include <glm/glm.hpp>
#include <string>
#include <string_view>
#include <unordered_map>

#include "gl.h"

namespace cvt::render {

class ShaderProgram {
 public:
  // Compiles and links; throws std::runtime_error with the file name and the driver's log.
  ShaderProgram(std::string_view vertex_file, std::string_view fragment_file);
  ~ShaderProgram();
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;

  void use() const { glUseProgram(id_); }
  // Setters for the program in use; unknown names (optimised away) are ignored.
  void set(const char* name, const glm::mat4& value);
  void set(const char* name, const glm::vec4& value);
  void set(const char* name, const glm::vec3& value);
  void set(const char* name, float value);
  void set(const char* name, int value);
  void set(const char* name, bool value) { set(name, int(value)); }

 private:
  GLint location(const char* name);
  GLuint id_ = 0;
  std::unordered_map<std::string, GLint> locations_;
};

}  // namespace cvt::render
