// The shaders of shaders/*.glsl, embedded at build time (shaders/embed_shaders.cmake).
#pragma once

#include <string_view>

namespace cvt::render {

// The text of shader file `name` (e.g. "mesh.vert.glsl"); empty if there is none.
std::string_view shader_source(std::string_view name);

}  // namespace cvt::render
