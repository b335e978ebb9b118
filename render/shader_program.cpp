#include "shader_program.h"

#include <glm/gtc/type_ptr.hpp>
#include <stdexcept>
#include <vector>

#include "shader_sources.h"

namespace cvt::render {
namespace {

GLuint compile(GLenum type, std::string_view file) {
  const std::string_view text = shader_source(file);
  if (text.empty()) throw std::runtime_error("shader " + std::string(file) + " is not embedded");
  const GLuint id = glCreateShader(type);
  const char* source = text.data();
  const GLint length = GLint(text.size());
  glShaderSource(id, 1, &source, &length);
  glCompileShader(id);
  GLint ok = 0;
  glGetShaderiv(id, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint size = 0;
    glGetShaderiv(id, GL_INFO_LOG_LENGTH, &size);
    std::vector<char> log(std::size_t(std::max(size, 1)));
    glGetShaderInfoLog(id, size, nullptr, log.data());
    glDeleteShader(id);
    throw std::runtime_error("shader " + std::string(file) + ": " + log.data());
  }
  return id;
}

}  // namespace

ShaderProgram::ShaderProgram(std::string_view vertex_file, std::string_view fragment_file) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex_file);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fragment_file);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  id_ = glCreateProgram();
  glAttachShader(id_, vs);
  glAttachShader(id_, fs);
  glLinkProgram(id_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(id_, GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint size = 0;
    glGetProgramiv(id_, GL_INFO_LOG_LENGTH, &size);
    std::vector<char> log(std::size_t(std::max(size, 1)));
    glGetProgramInfoLog(id_, size, nullptr, log.data());
    glDeleteProgram(id_);
    throw std::runtime_error("linking " + std::string(vertex_file) + " + " +
                             std::string(fragment_file) + ": " + log.data());
  }
}

ShaderProgram::~ShaderProgram() {
  if (id_) glDeleteProgram(id_);
}

GLint ShaderProgram::location(const char* name) {
  auto it = locations_.find(name);
  if (it == locations_.end()) it = locations_.emplace(name, glGetUniformLocation(id_, name)).first;
  return it->second;
}

void ShaderProgram::set(const char* name, const glm::mat4& v) {
  glUniformMatrix4fv(location(name), 1, GL_FALSE, glm::value_ptr(v));
}
void ShaderProgram::set(const char* name, const glm::vec4& v) {
  glUniform4fv(location(name), 1, glm::value_ptr(v));
}
void ShaderProgram::set(const char* name, const glm::vec3& v) {
  glUniform3fv(location(name), 1, glm::value_ptr(v));
}
void ShaderProgram::set(const char* name, float v) {
  glUniform1f(location(name), v);
}
void ShaderProgram::set(const char* name, int v) {
  glUniform1i(location(name), v);
}

}  // namespace cvt::render
