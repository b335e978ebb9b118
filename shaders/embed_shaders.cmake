# Turns the .glsl files given in SHADERS (paths joined with '|') into OUTPUT, a C++ file that holds
# each one as a raw string literal, so the viewer finds its shaders whatever the working folder.
# Run at build time: cmake -DSHADERS=... -DOUTPUT=... -P embed_shaders.cmake
string(REPLACE "|" ";" SHADERS "${SHADERS}")
set(body "")
foreach(path IN LISTS SHADERS)
  get_filename_component(name "${path}" NAME)
  file(READ "${path}" text)
  string(FIND "${text}" ")glsl\"" clash)
  if(NOT clash EQUAL -1)
    message(FATAL_ERROR "${path} contains the raw-string delimiter )glsl\"")
  endif()
  string(APPEND body "    {\"${name}\", R\"glsl(${text})glsl\"},\n")
endforeach()
set(code "// Generated from shaders/*.glsl by shaders/embed_shaders.cmake; do not edit.
#include <string_view>
#include <utility>

#include \"shader_sources.h\"

namespace cvt::render {
namespace {
constexpr std::pair<std::string_view, std::string_view> kShaders[] = {
${body}};
}  // namespace

std::string_view shader_source(std::string_view name) {
  for (const auto& [key, text] : kShaders)
    if (key == name) return text;
  return {};
}

}  // namespace cvt::render
")
# Only touch the file when it changes, so an unchanged shader does not trigger a rebuild.
if(EXISTS "${OUTPUT}")
  file(READ "${OUTPUT}" old)
  if(old STREQUAL code)
    return()
  endif()
endif()
file(WRITE "${OUTPUT}" "${code}")
