// Flat-shaded faces with a head light (two-sided, so cut faces and inner faces light alike) and
// optional anti-aliased edge lines from the barycentrics.
#version 330 core

in vec3 v_view_position;
in vec4 v_color;
in vec3 v_barycentric;

uniform float u_alpha;         // multiplies the vertex alpha (ghosted geometry)
uniform bool u_edges;          // draw the triangle edges
uniform float u_edge_width;    // in pixels

out vec4 frag_color;

void main() {
  vec3 normal = normalize(cross(dFdx(v_view_position), dFdy(v_view_position)));
  vec3 to_eye = normalize(-v_view_position);
  if (dot(normal, to_eye) < 0.0) normal = -normal;
  float diffuse = max(dot(normal, to_eye), 0.0);
  float specular = pow(diffuse, 48.0) * 0.18;
  vec3 color = v_color.rgb * (0.32 + 0.68 * diffuse) + vec3(specular);
  if (u_edges) {
    vec3 width = fwidth(v_barycentric) * u_edge_width;
    vec3 ramp = smoothstep(vec3(0.0), width, v_barycentric);
    float inside = min(min(ramp.x, ramp.y), ramp.z);
    color = mix(color * 0.45, color, inside);  // a darker shade of the face: readable on any colour
  }
  frag_color = vec4(color, v_color.a * u_alpha);
}
