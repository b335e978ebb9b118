// The 3D view's geometry as flat vertex arrays ready to upload: triangle soups (three vertices
// per face, so faces stay flat-shaded and the shader finds corners by vertex id) and point lists.
// GL-free, so what the clipping and highlighting show is unit tested.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "colormap.h"
#include "fields/marching_cubes.h"
#include "quality_selection.h"
#include "scene_data.h"

namespace cvt::render {

// 16 bytes: position (world mm) and colour; the layout of both vertex buffers.
struct ColoredVertex {
  float position[3];
  Rgba8 color;
};
static_assert(sizeof(ColoredVertex) == 16);

struct MeshColoring {
  std::optional<Measure> measure;      // colour the cut faces by this measure (else `cut`)
  bool measure_on_boundary = false;    // also colour the boundary faces by the measure
  Rgba8 surface{214, 196, 170, 255};   // boundary faces
  Rgba8 cut{236, 226, 205, 255};       // faces exposed by the clip, without a measure
  Rgba8 highlight{255, 60, 200, 255};  // tets selected in the quality panel
};

// The colour of one value of a measure (red = bad, green = good, over measure_scale(m)).
Rgba8 measure_color(Measure m, double value);

struct MeshSoups {
  std::vector<ColoredVertex> solid;  // opaque faces
  std::vector<ColoredVertex> ghost;  // drawn translucent over the highlighted tets
  std::size_t kept_tets = 0;
  std::size_t cut_faces = 0;         // faces exposed by the clip
  std::size_t highlighted_tets = 0;  // selected and kept
};

// The tets `clip` keeps (all without a clip): their visible faces (mesh boundary and faces the
// cut exposes). With a non-empty `highlight` (1 per selected tet), the selected kept tets are
// drawn whole and solid, and the visible faces become the ghost.
MeshSoups build_mesh_soups(const MeshLayers& layers, const ClipPlane* clip,
                           const MeshColoring& coloring,
                           const std::vector<std::uint8_t>* highlight = nullptr);

// A triangle surface in one colour (the object's marching-cubes surface before a mesh exists).
void append_surface(const TriangleSurface& surface, Rgba8 color, std::vector<ColoredVertex>& out);

// Points in one colour; with `clip`, points in front of the plane are left out.
void append_points(const std::vector<Vec3>& points, Rgba8 color, const ClipPlane* clip,
                   std::vector<ColoredVertex>& out);

}  // namespace cvt::render
