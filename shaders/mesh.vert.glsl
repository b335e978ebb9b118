// Triangle soups (boundary surface, faces of the kept tets): world positions (mm) and an RGBA
// colour per vertex. Normals come from screen-space derivatives in mesh.frag, and the corner
// index (gl_VertexID % 3, the soup is not indexed) gives barycentrics for the edge lines.
#version 330 core

layout(location = 0) in vec3 a_position;
layout(location = 1) in vec4 a_color;

uniform mat4 u_view;
uniform mat4 u_projection;
// World-space plane (n, d): fragments with dot(n, p) + d > 0 are clipped when enabled. Used for
// geometry that is not made of whole tets (marching-cubes surface, points).
uniform vec4 u_clip_plane;
uniform bool u_clip_enabled;

out vec3 v_view_position;
out vec4 v_color;
out vec3 v_barycentric;

void main() {
  vec4 world = vec4(a_position, 1.0);
  vec4 view = u_view * world;
  v_view_position = view.xyz;
  v_color = a_color;
  int corner = gl_VertexID % 3;
  v_barycentric = vec3(corner == 0, corner == 1, corner == 2);
  gl_ClipDistance[0] = u_clip_enabled ? -dot(u_clip_plane, world) : 1.0;
  gl_Position = u_projection * view;
}
