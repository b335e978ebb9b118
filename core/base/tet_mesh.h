// A tetrahedral mesh in world coordinates (mm), the output of stages 5–6.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "base/vec3.h"

namespace cvt {

using Tet = std::array<std::int32_t, 4>;
using Triangle = std::array<std::int32_t, 3>;

struct TetMesh {
  std::vector<Vec3> vertices;        // world positions (mm)
  std::vector<Tet> tets;             // vertex indices; positively oriented: (b−a)·((c−a)×(d−a)) > 0
  std::vector<std::int32_t> labels;  // per-tet subdomain label (empty = all 1)
};

// Signed volume (mm³) of tet t; positive for a positively oriented tet.
inline double signed_volume(const TetMesh& m, const Tet& t) {
  const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]],
             &d = m.vertices[t[3]];
  return dot(b - a, cross(c - a, d - a)) / 6.0;
}

// The faces of t, each oriented so its normal (right-hand rule) points out of t.
inline std::array<Triangle, 4> outward_faces(const Tet& t) {
  return {{{t[1], t[2], t[3]}, {t[0], t[3], t[2]}, {t[0], t[1], t[3]}, {t[0], t[2], t[1]}}};
}

// For each face 4·t + k (k indexing outward_faces(tets[t])): a face of another tet with the
// same three corners, or −1 where there is none (a boundary face). Where more than two tets
// share a face (an invalid mesh), they are linked in a cycle. Corners must be in
// [0, vertex_count) (std::invalid_argument otherwise).
std::vector<std::int64_t> face_neighbours(std::size_t vertex_count, const std::vector<Tet>& tets);

// Faces used by exactly one tet, oriented outward (the mesh's boundary surface).
std::vector<Triangle> boundary_triangles(const TetMesh& mesh);
// The boundary faces as (tet index × 4 + face index into outward_faces(tet)), in the order
// boundary_triangles() returns them, so writers can give a triangle the label of its tet.
std::vector<std::int64_t> boundary_faces(const TetMesh& mesh);

}  // namespace cvt
