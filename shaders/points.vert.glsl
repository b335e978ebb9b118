// Point sprites: one vertex per sample (world mm in 3D, slice mm in the 2D view), a colour each,
// a fixed size in pixels (already multiplied by the screenshot scale).
#version 330 core

layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_color;

uniform mat4 u_view;
uniform mat4 u_projection;
uniform float u_point_size;  // pixels
uniform vec4 u_clip_plane;   // as in mesh.vert
uniform bool u_clip_enabled;

out vec4 v_color;

void main() {
  vec4 world = vec4(a_position, 1.0);
  gl_ClipDistance[0] = u_clip_enabled ? -dot(u_clip_plane, world) : 1.0;
  gl_Position = u_projection * (u_view * world);
  gl_PointSize = u_point_size;
  v_color = a_color;
}
