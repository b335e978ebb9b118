// Makes the boundary of a tet set a closed 2-manifold by peeling tets: flat tets on the
// boundary go, and where tets meet only along an edge or at a vertex (two fans), all but the
// largest fan go; where the tets around a vertex form one fan but the boundary still touches
// itself there, the vertex's whole star goes. Pole removal leaves such pinches in deep concavities and thin parts; removing
// (rather than adding) tets never places a tet outside the object.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "base/tet_mesh.h"

namespace cvt {

struct ManifoldRepairReport {
  std::size_t flat_removed = 0;         // boundary tets with (near) zero volume
  std::size_t edge_fans_removed = 0;    // tets removed at non-manifold edges
  std::size_t vertex_fans_removed = 0;  // tets removed at non-manifold vertices
  int passes = 0;
  bool manifold = false;                // the boundary is a closed 2-manifold at the end
};

// Vertices where a boundary (its triangles, in any order and orientation) is not a disc (their
// link is not one cycle): the ends of non-manifold edges and the points where two sheets touch.
std::vector<std::int32_t> pinched_vertices(std::size_t vertex_count,
                                           const std::vector<Triangle>& boundary);

// The same test for one vertex, given its link: the far edges of its boundary triangles (vertex
// pairs, in any order). False for an empty link (a vertex off the boundary).
bool link_is_pinched(const std::vector<std::pair<std::int32_t, std::int32_t>>& link);

// tets index `points`; removed tets are appended to `removed` (as corner positions) when given.
ManifoldRepairReport repair_boundary_manifold(const std::vector<Vec3>& points,
                                              std::vector<Tet>& tets,
                                              std::vector<std::array<Vec3, 4>>* removed = nullptr);

}  // namespace cvt

namespace cvt {

// Drops face-connected groups of tets whose volume is below `fraction` of the largest group's
// (stray slivers left by the rules above); returns how many tets went. Removing a whole group
// never breaks the manifoldness of the others.
std::size_t remove_small_tet_components(const std::vector<Vec3>& points, std::vector<Tet>& tets,
                                        double fraction,
                                        std::vector<std::array<Vec3, 4>>* removed = nullptr);

// The same with the groups given: component[t] numbers tet t's group (small non-negative ids).
std::size_t remove_small_tet_components(const std::vector<Vec3>& points, std::vector<Tet>& tets,
                                        const std::vector<std::int32_t>& component,
                                        double fraction,
                                        std::vector<std::array<Vec3, 4>>* removed = nullptr);

// Whether tet t is flat: |volume| at most 1e-9 × its longest edge cubed.
bool is_flat_tet(const std::vector<Vec3>& points, const Tet& t);

}  // namespace cvt
