#include "clip_selection.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>

namespace cvt::render {
namespace {

// A face with sorted vertex ids and where it came from (4 t + f).
struct FaceKey {
  std::array<std::int32_t, 3> v;
  std::int32_t slot;
  bool operator<(const FaceKey& o) const { return v != o.v ? v < o.v : slot < o.slot; }
};

}  // namespace

TetNeighbours compute_tet_neighbours(const TetMesh& mesh) {
  const std::size_t n = mesh.tets.size();
  std::vector<FaceKey> faces(4 * n);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t t) {
    const auto f = outward_faces(mesh.tets[t]);
    for (int k = 0; k < 4; ++k) {
      std::array<std::int32_t, 3> v = f[k];
      std::sort(v.begin(), v.end());
      faces[4 * t + k] = {v, std::int32_t(4 * t + k)};
    }
  });
  tbb::parallel_sort(faces.begin(), faces.end());
  TetNeighbours result;
  result.across.assign(4 * n, -1);
  // Equal keys are adjacent after sorting; a face shared by exactly two tets links them (a
  // non-manifold face used three times links nobody, so it shows up as visible).
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].v == faces[i].v) ++j;
    if (j - i == 2) {
      result.across[faces[i].slot] = faces[i + 1].slot / 4;
      result.across[faces[i + 1].slot] = faces[i].slot / 4;
    }
    i = j;
  }
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
