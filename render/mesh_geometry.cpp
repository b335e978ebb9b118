#include "mesh_geometry.h"

#include <cmath>

namespace cvt::render {
namespace {

void append_vertex(const Vec3& p, Rgba8 c, std::vector<ColoredVertex>& out) {
  out.push_back({{float(p.x), float(p.y), float(p.z)}, c});
}

void append_face(const TetMesh& mesh, const Tet& tet, int face, Rgba8 c,
                 std::vector<ColoredVertex>& out) {
  const Triangle tri = outward_faces(tet)[face];
  for (int k = 0; k < 3; ++k) append_vertex(mesh.vertices[tri[k]], c, out);
}

}  // namespace

Rgba8 measure_color(Measure m, double value) {
  const MeasureScale s = measure_scale(m);
  double t = normalize_value(value, s.lo, s.hi);
  if (!s.higher_is_better) t = 1.0 - t;
  // An inverted (negative) or degenerate tet is worst whatever the scale says.
  if (std::isnan(value)) t = 0.0;
  return colormap_color(Colormap::RedYellowGreen, t);
}

MeshSoups build_mesh_soups(const MeshLayers& layers, const ClipPlane* clip,
                           const MeshColoring& coloring,
                           const std::vector<std::uint8_t>* highlight) {
  const TetMesh& mesh = layers.mesh;
  MeshSoups soups;
  const std::vector<std::uint8_t> kept =
      clip ? tets_kept_by_plane(mesh, *clip) : std::vector<std::uint8_t>(mesh.tets.size(), 1);
  for (std::uint8_t k : kept) soups.kept_tets += k;
  const std::vector<double>* values =
      coloring.measure ? &layers.measures[int(*coloring.measure)] : nullptr;
  auto face_color = [&](std::int32_t t, bool boundary) {
    if (values && (!boundary || coloring.measure_on_boundary))
      return measure_color(*coloring.measure, (*values)[t]);
    return boundary ? coloring.surface : coloring.cut;
  };
  bool any_highlight = false;
  if (highlight)
    for (std::size_t t = 0; t < mesh.tets.size(); ++t)
      if ((*highlight)[t] && kept[t]) {
        any_highlight = true;
        ++soups.highlighted_tets;
        for (int f = 0; f < 4; ++f)
          append_face(mesh, mesh.tets[t], f, coloring.highlight, soups.solid);
      }
  std::vector<ColoredVertex>& faces_out = any_highlight ? soups.ghost : soups.solid;
  for (const VisibleFace& vf : visible_faces(mesh, layers.neighbours, kept)) {
    soups.cut_faces += !vf.on_boundary;
    append_face(mesh, mesh.tets[vf.tet], vf.face, face_color(vf.tet, vf.on_boundary), faces_out);
  }
  return soups;
}

void append_surface(const TriangleSurface& surface, Rgba8 color, std::vector<ColoredVertex>& out) {
  out.reserve(out.size() + 3 * surface.triangles.size());
  for (const Triangle& tri : surface.triangles)
    for (int k = 0; k < 3; ++k) append_vertex(surface.vertices[tri[k]], color, out);
}

void append_points(const std::vector<Vec3>& points, Rgba8 color, const ClipPlane* clip,
                   std::vector<ColoredVertex>& out) {
  for (const Vec3& p : points)
    if (!clip || dot(clip->normal, p - clip->point) <= 0) append_vertex(p, color, out);
}

}  // namespace cvt::render
