// Which tets a clipping plane keeps, and which of their faces can be seen. The plane removes
// WHOLE tets (a tet stays when its centroid is on the kept side), so the cut shows real tet
// faces, coloured by quality, instead of a planar section. GL-free and unit tested.
#pragma once

#include <cstdint>
#include <vector>

#include "base/tet_mesh.h"

namespace cvt::render {

// Tets whose centroid c has dot(normal, c − point) > 0 are removed ("in front of" the plane);
// the rest are kept. normal need not be unit length.
struct ClipPlane {
  Vec3 point;
  Vec3 normal{1, 0, 0};
};

// For every tet t and face f (face f is outward_faces(t)[f], opposite vertex f), the tet on the
// other side of that face, or −1 on the mesh boundary: neighbours[4 t + f].
struct TetNeighbours {
  std::vector<std::int32_t> across;
};
TetNeighbours compute_tet_neighbours(const TetMesh& mesh);

Vec3 tet_centroid(const TetMesh& mesh, const Tet& tet);

// 1 for the tets the plane keeps, 0 for the removed ones.
std::vector<std::uint8_t> tets_kept_by_plane(const TetMesh& mesh, const ClipPlane& plane);

// A face of a kept tet that nothing kept covers: on the mesh boundary, or exposed by the cut
// (its neighbour was removed).
struct VisibleFace {
  std::int32_t tet = 0;
  std::uint8_t face = 0;     // index into outward_faces(tet)
  bool on_boundary = false;  // true: mesh boundary; false: exposed by the clip
};
// Faces of the kept tets (kept[t] != 0) that bound the kept set, tet by tet.
std::vector<VisibleFace> visible_faces(const TetMesh& mesh, const TetNeighbours& neighbours,
                                       const std::vector<std::uint8_t>& kept);

// The clip plane of the viewer's controls: perpendicular to world axis `axis` (0, 1, 2) at
// fraction `position` ∈ [0, 1] of the box [lo, hi] along it. The tets below it (lower
// coordinates: the side facing the default camera for axis 1) are removed, or the ones above
// it when `flip`.
ClipPlane axis_clip_plane(const Vec3& lo, const Vec3& hi, int axis, double position, bool flip);

}  // namespace cvt::render
