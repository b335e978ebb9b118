// Rule 3's building blocks on hand-made tet sets: where a boundary pinches, how the peeling
// repairs it, and rule 4's removal of small components.
#include <gtest/gtest.h>

#include "meshing/manifold_repair.h"

namespace cvt {
namespace {

// A unit corner tet at `at`, positively oriented, using vertices first..first+3.
void add_tet(std::vector<Vec3>& points, std::vector<Tet>& tets, const Vec3& at, double size) {
  const std::int32_t f = std::int32_t(points.size());
  for (const Vec3& d : {Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}})
    points.push_back(at + d * size);
  tets.push_back({f, f + 1, f + 2, f + 3});
}

TEST(PinchedVertices, ATetAndTwoTetsSharingAFaceArePinchFree) {
  std::vector<Vec3> p;
  std::vector<Tet> t;
  add_tet(p, t, {0, 0, 0}, 1);
  EXPECT_TRUE(pinched_vertices(p.size(), boundary_triangles({p, t, {}})).empty());
  p.push_back({1, 1, 1});
  t.push_back({1, 2, 3, 4});  // on the other side of face {1,2,3}
  EXPECT_TRUE(pinched_vertices(p.size(), boundary_triangles({p, t, {}})).empty());
}

TEST(PinchedVertices, TetsTouchingAtAVertexOrAlongAnEdgePinchThere) {
  // Two tets sharing vertex 0 only (a bow tie): its link is two triangles, not one cycle.
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  std::vector<Tet> t = {{0, 1, 2, 3}, {0, 5, 4, 6}};
  EXPECT_EQ(pinched_vertices(p.size(), boundary_triangles({p, t, {}})), (std::vector<std::int32_t>{0}));
  // Two tets sharing edge {0,1} only: both ends of the edge pinch, nothing else.
  p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}, {0, 0, -1}};
  t = {{0, 1, 2, 3}, {0, 1, 4, 5}};
  EXPECT_EQ(pinched_vertices(p.size(), boundary_triangles({p, t, {}})),
            (std::vector<std::int32_t>{0, 1}));
}

TEST(LinkIsPinched, OneCycleInAnyOrderIsADiscAndAnythingElsePinches) {
  // A vertex inside a boundary sheet: its link is one cycle, whatever the edges' order and
  // direction.
  EXPECT_FALSE(link_is_pinched({{1, 2}, {3, 4}, {2, 3}, {1, 4}}));
  EXPECT_FALSE(link_is_pinched({{2, 1}, {4, 3}, {3, 2}, {4, 1}}));
  EXPECT_FALSE(link_is_pinched({}));  // off the boundary
  // Two sheets touching at the vertex (two cycles), an open fan (a path), and a
  // non-manifold edge (a link vertex of degree 4).
  EXPECT_TRUE(link_is_pinched({{1, 2}, {2, 3}, {3, 1}, {4, 5}, {5, 6}, {6, 4}}));
  EXPECT_TRUE(link_is_pinched({{1, 2}, {2, 3}, {3, 4}}));
  EXPECT_TRUE(link_is_pinched({{1, 2}, {2, 3}, {3, 1}, {1, 4}, {4, 5}, {5, 1}}));
}

TEST(RepairBoundaryManifold, AnEdgePinchLosesItsSmallerFan) {
  // Two tets on edge {0,1}, plus a third glued to the first by a face: fans of 2 and 1 tets.
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}, {0, 0, -1}, {0.5, 0.5, 0.5}};
  std::vector<Tet> t = {{0, 1, 2, 3}, {0, 1, 4, 5}, {1, 2, 3, 6}};
  ASSERT_FALSE(pinched_vertices(p.size(), boundary_triangles({p, t, {}})).empty());
  std::vector<std::array<Vec3, 4>> removed;
  const ManifoldRepairReport report = repair_boundary_manifold(p, t, &removed);
  EXPECT_TRUE(report.manifold);
  EXPECT_EQ(t, (std::vector<Tet>{{0, 1, 2, 3}, {1, 2, 3, 6}}));
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0][2], p[4]);
  EXPECT_TRUE(pinched_vertices(p.size(), boundary_triangles({p, t, {}})).empty());
}

TEST(RemoveSmallTetComponents, DropsGroupsBelowTheFractionAndKeepsFaceConnectedOnes) {
  std::vector<Vec3> p;
  std::vector<Tet> t;
  add_tet(p, t, {0, 0, 0}, 1);
  p.push_back({1, 1, 1});
  t.push_back({1, 2, 3, 4});      // face-connected to the first: one group of volume 1/6 + 1/3
  add_tet(p, t, {5, 0, 0}, 0.5);  // alone, volume 1/48: 0.042 of the big group
  add_tet(p, t, {9, 0, 0}, 0.9);  // alone, volume 0.1215: 0.243 of it
  std::vector<Tet> kept = t;
  EXPECT_EQ(remove_small_tet_components(p, kept, 0.04), 0u);
  std::vector<std::array<Vec3, 4>> removed;
  EXPECT_EQ(remove_small_tet_components(p, kept, 0.1, &removed), 1u);
  EXPECT_EQ(kept, (std::vector<Tet>{t[0], t[1], t[3]}));
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0][0], (Vec3{5, 0, 0}));
  EXPECT_EQ(remove_small_tet_components(p, kept, 0.25), 1u);  // 0.243 < 0.25
  EXPECT_EQ(kept, (std::vector<Tet>{t[0], t[1]}));
}

}  // namespace
}  // namespace cvt
