// The slice image is composed on the CPU (image, overlays, Voronoi cells) and shown with nearest
// filtering so voxels stay visible; alpha lets the 3D view show it as a translucent plane.
#version 330 core

in vec2 v_uv;

uniform sampler2D u_texture;
uniform float u_alpha;

out vec4 frag_color;

void main() {
  vec4 texel = texture(u_texture, v_uv);
  frag_color = vec4(texel.rgb, texel.a * u_alpha);
}
