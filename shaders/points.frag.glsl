// Round sprites shaded like small spheres, with a dark rim so neighbouring points stay apart.
#version 330 core

in vec4 v_color;

out vec4 frag_color;

void main() {
  vec2 p = gl_PointCoord * 2.0 - 1.0;
  float r2 = dot(p, p);
  if (r2 > 1.0) discard;
  float z = sqrt(1.0 - r2);
  float light = 0.45 + 0.55 * z;
  float rim = r2 > 0.72 ? 0.45 : 1.0;
  frag_color = vec4(v_color.rgb * light * rim, v_color.a);
}
