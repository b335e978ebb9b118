#include "clip_selection.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>

namespace cvt::render {

TetNeighbours compute_tet_neighbours(const TetMesh& mesh) {
  // Core links the faces of a face used more than twice in a cycle; here such a face links
  // nobody (a pair only where the partner links back), so it shows up as visible.
  const std::vector<std::int64_t> face = face_neighbours(mesh.vertices.size(), mesh.tets);
  TetNeighbours result;
  result.across.resize(face.size());
  tbb::parallel_for(std::size_t(0), face.size(), [&](std::size_t f) {
    const std::int64_t g = face[f];
    result.across[f] = g >= 0 && face[std::size_t(g)] == std::int64_t(f) ? std::int32_t(g / 4) : -1;
  });
  return result;
}

Vec3 tet_centroid(const TetMesh& mesh, const Tet& tet) {
  return (mesh.vertices[tet[0]] + mesh.vertices[tet[1]] + mesh.vertices[tet[2]] +
          mesh.vertices[tet[3]]) *
         0.25;
}

std::vector<std::uint8_t> tets_kept_by_plane(const TetMesh& mesh, const ClipPlane& plane) {
  std::vector<std::uint8_t> kept(mesh.tets.size());
  tbb::parallel_for(std::size_t(0), mesh.tets.size(), [&](std::size_t t) {
    kept[t] = dot(plane.normal, tet_centroid(mesh, mesh.tets[t]) - plane.point) > 0 ? 0 : 1;
  });
  return kept;
}

std::vector<VisibleFace> visible_faces(const TetMesh& mesh, const TetNeighbours& neighbours,
                                       const std::vector<std::uint8_t>& kept) {
  std::vector<VisibleFace> out;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    if (!kept[t]) continue;
    for (int f = 0; f < 4; ++f) {
      const std::int32_t other = neighbours.across[4 * t + f];
      if (other < 0)
        out.push_back({std::int32_t(t), std::uint8_t(f), true});
      else if (!kept[other])
        out.push_back({std::int32_t(t), std::uint8_t(f), false});
    }
  }
  return out;
}

ClipPlane axis_clip_plane(const Vec3& lo, const Vec3& hi, int axis, double position, bool flip) {
  ClipPlane plane;
  plane.point = lo + (hi - lo) * std::clamp(position, 0.0, 1.0);
  plane.normal = {0, 0, 0};
  plane.normal[axis] = flip ? 1 : -1;
  return plane;
}

}  // namespace cvt::render
