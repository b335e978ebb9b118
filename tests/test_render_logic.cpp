// The viewer's GL-free drawing logic (render/): which whole tets a clip keeps and which faces
// show, colours, cameras and quality selections. No window or GL context.
// (Slice pictures, the surface preview and the pipeline snapshots: test_render_data.cpp.)
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "camera.h"
#include "clip_selection.h"
#include "colormap.h"
#include "fields/marching_cubes.h"
#include "mesh_geometry.h"
#include "evaluate/quality.h"
#include "quality_selection.h"
#include "scene_data.h"

using namespace cvt;
using namespace cvt::render;

namespace {

// A 4 × 3 × 3 block of voxels (1 mm) split into 6 tets each: 216 conforming tets.
TetMesh block_mesh() {
  Grid g;
  g.dims = {6, 5, 5};
  Mask m(g, 0);
  for (int k = 1; k < 4; ++k)
    for (int j = 1; j < 4; ++j)
      for (int i = 1; i < 5; ++i) m.at(i, j, k) = 1;
  return voxel_tet_mesh(m);
}

std::vector<Triangle> face_triangles(const TetMesh& mesh, const std::vector<VisibleFace>& faces) {
  std::vector<Triangle> out;
  for (const VisibleFace& f : faces) out.push_back(outward_faces(mesh.tets[f.tet])[f.face]);
  return out;
}

}  // namespace

TEST(ClipSelection, NeighboursMatchTheBoundary) {
  const TetMesh mesh = block_mesh();
  ASSERT_EQ(mesh.tets.size(), 216u);
  const TetNeighbours n = compute_tet_neighbours(mesh);
  std::size_t boundary = 0;
  for (std::size_t slot = 0; slot < n.across.size(); ++slot) {
    const std::int32_t other = n.across[slot];
    if (other < 0) {
      ++boundary;
      continue;
    }
    // Symmetric: the neighbour sees this tet across one of its faces.
    bool back = false;
    for (int f = 0; f < 4; ++f) back |= n.across[4 * other + f] == std::int32_t(slot / 4);
    EXPECT_TRUE(back);
  }
  EXPECT_EQ(boundary, boundary_triangles(mesh).size());
}

TEST(ClipSelection, KeepsWholeTetsByCentroidAndShowsAClosedSurface) {
  const TetMesh mesh = block_mesh();
  const TetNeighbours n = compute_tet_neighbours(mesh);
  // Remove the tets whose centroid has x > 2.3 (through the middle of a voxel column).
  const ClipPlane plane{{2.3, 0, 0}, {1, 0, 0}};
  const auto kept = tets_kept_by_plane(mesh, plane);
  std::size_t kept_count = 0;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    const double cx = tet_centroid(mesh, mesh.tets[t]).x;
    EXPECT_EQ(kept[t] != 0, cx <= 2.3) << "tet " << t;
    kept_count += kept[t];
  }
  EXPECT_GT(kept_count, 0u);
  EXPECT_LT(kept_count, mesh.tets.size());
  // Some kept tets reach beyond the plane: whole tets, not a planar section.
  double max_x = 0;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    if (kept[t])
      for (int v : mesh.tets[t]) max_x = std::max(max_x, mesh.vertices[v].x);
  EXPECT_GT(max_x, 2.3);

  const auto faces = visible_faces(mesh, n, kept);
  std::size_t cut = 0;
  for (const VisibleFace& f : faces) {
    EXPECT_TRUE(kept[f.tet]);
    const std::int32_t other = n.across[4 * f.tet + f.face];
    EXPECT_EQ(f.on_boundary, other < 0);
    if (!f.on_boundary) {
      EXPECT_FALSE(kept[other]);
      ++cut;
    }
  }
  EXPECT_GT(cut, 0u);
  // What is drawn is the boundary of the kept tets: a closed, consistently oriented surface.
  const SurfaceTopology topo = surface_topology(face_triangles(mesh, faces), mesh.vertices.size());
  EXPECT_TRUE(topo.closed_manifold);
  EXPECT_EQ(topo.euler_characteristic, 2);
}

TEST(ClipSelection, AxisPlaneRemovesTheLowerSideUnlessFlipped) {
  const TetMesh mesh = block_mesh();
  const Vec3 lo{0.5, 0.5, 0.5}, hi{4.5, 3.5, 3.5};
  auto count = [&](double position, bool flip) {
    const auto kept = tets_kept_by_plane(mesh, axis_clip_plane(lo, hi, 0, position, flip));
    return std::size_t(std::count(kept.begin(), kept.end(), 1));
  };
  EXPECT_EQ(count(0.0, false), mesh.tets.size());  // nothing below the lowest x
  EXPECT_EQ(count(1.0, false), 0u);
  EXPECT_EQ(count(0.0, true), 0u);
  EXPECT_EQ(count(0.5, false) + count(0.5, true), mesh.tets.size() + 0u);
  EXPECT_GT(count(0.25, false), count(0.75, false));
}

TEST(MeshGeometry, SoupsFollowTheClipAndTheHighlight) {
  MeshLayers layers;
  layers.mesh = block_mesh();
  layers.neighbours = compute_tet_neighbours(layers.mesh);
  layers.measures = tet_measures(layers.mesh);
  MeshColoring coloring;
  coloring.measure = Measure::VOverRmc3;
  const MeshSoups whole = build_mesh_soups(layers, nullptr, coloring);
  EXPECT_EQ(whole.kept_tets, 216u);
  EXPECT_EQ(whole.cut_faces, 0u);
  EXPECT_EQ(whole.solid.size(), 3 * boundary_triangles(layers.mesh).size());
  EXPECT_TRUE(whole.ghost.empty());
  for (const ColoredVertex& v : whole.solid) EXPECT_EQ(v.color, coloring.surface);

  const ClipPlane plane{{2.3, 0, 0}, {1, 0, 0}};
  const MeshSoups clipped = build_mesh_soups(layers, &plane, coloring);
  EXPECT_GT(clipped.cut_faces, 0u);
  std::size_t measure_coloured = 0;
  for (const ColoredVertex& v : clipped.solid) measure_coloured += !(v.color == coloring.surface);
  EXPECT_EQ(measure_coloured, 3 * clipped.cut_faces);

  std::vector<std::uint8_t> highlight(layers.mesh.tets.size(), 0);
  highlight[0] = highlight[5] = 1;
  const MeshSoups lit = build_mesh_soups(layers, nullptr, coloring, &highlight);
  EXPECT_EQ(lit.highlighted_tets, 2u);
  EXPECT_EQ(lit.solid.size(), 2u * 12);
  EXPECT_EQ(lit.ghost.size(), whole.solid.size());
}

TEST(Colormap, EndsClampingAndLabels) {
  const Rgba8 lo = colormap_color(Colormap::Viridis, 0), hi = colormap_color(Colormap::Viridis, 1);
  EXPECT_NEAR(lo.r, 68, 2);
  EXPECT_NEAR(lo.b, 84, 2);
  EXPECT_NEAR(hi.r, 253, 2);
  EXPECT_NEAR(hi.g, 231, 2);
  EXPECT_EQ(colormap_color(Colormap::Viridis, -3), lo);
  EXPECT_EQ(colormap_color(Colormap::Viridis, 7), hi);
  EXPECT_EQ(colormap_color(Colormap::Viridis, std::nan("")), (Rgba8{128, 128, 128, 255}));
  // Viridis gets lighter all the way (what makes it readable as a scale).
  double previous = -1;
  for (int i = 0; i <= 50; ++i) {
    const double l = luma(colormap_color(Colormap::Viridis, i / 50.0));
    EXPECT_GE(l, previous - 1e-9);
    previous = l;
  }
  // Quality: red at the bad end, green at the good end.
  const Rgba8 bad = colormap_color(Colormap::RedYellowGreen, 0);
  const Rgba8 good = colormap_color(Colormap::RedYellowGreen, 1);
  EXPECT_GT(bad.r, bad.g);
  EXPECT_GT(good.g, good.r);
  EXPECT_DOUBLE_EQ(normalize_value(5, 0, 10), 0.5);
  EXPECT_DOUBLE_EQ(normalize_value(-5, 0, 10), 0.0);
  EXPECT_DOUBLE_EQ(normalize_value(3, 2, 2), 0.5);
  // Neighbouring labels (as Voronoi cells often are) get visibly different colours.
  for (int label = 0; label < 200; ++label) {
    const Rgba8 a = label_color(label), b = label_color(label + 1);
    const int diff = std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
    EXPECT_GT(diff, 40) << label;
    EXPECT_EQ(a.a, 255);
  }
  EXPECT_EQ(label_color(-1).a, 0);
  const Rgba8 base{10, 20, 30, 255}, top{200, 100, 0, 255};
  EXPECT_EQ(blend_over(base, Rgba8{200, 100, 0, 0}), base);
  EXPECT_EQ(blend_over(base, top), top);
}

TEST(Camera, FitFramesTheBoxAndControlsBehave) {
  OrbitCamera cam;
  const glm::vec3 lo(-20, 5, 100), hi(80, 45, 160), centre = 0.5f * (lo + hi);
  for (float aspect : {0.5f, 1.0f, 1.6f}) {
    cam.fit(lo, hi, aspect);
    EXPECT_NEAR(glm::length(cam.target - centre), 0.0f, 1e-4f);
    const glm::mat4 pv = cam.projection(aspect) * cam.view();
    auto ndc = [&](const glm::vec3& p) {
      const glm::vec4 clip = pv * glm::vec4(p, 1.0f);
      return glm::vec3(clip) / clip.w;
    };
    // The fit is tight for rounded objects: the middles of the box faces are in view, its
    // corners only just outside at worst; nothing is cut by the depth range.
    for (int a = 0; a < 3; ++a)
      for (float side : {0.0f, 1.0f}) {
        glm::vec3 p = centre;
        p[a] = side ? hi[a] : lo[a];
        const glm::vec3 n = ndc(p);
        EXPECT_LE(std::abs(n.x), 1.0f) << aspect;
        EXPECT_LE(std::abs(n.y), 1.0f) << aspect;
      }
    for (int c = 0; c < 8; ++c) {
      const glm::vec3 n =
          ndc({(c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z});
      EXPECT_LE(std::abs(n.x), 1.3f) << aspect;
      EXPECT_LE(std::abs(n.y), 1.3f) << aspect;
      EXPECT_LE(std::abs(n.z), 1.0f) << aspect;
    }
  }
  const float d = cam.distance;
  cam.orbit(40, 10000);
  EXPECT_LE(cam.pitch_deg, 89.0f);
  EXPECT_NEAR(glm::length(cam.eye() - cam.target), d, 1e-3f * d);
  const glm::vec3 t = cam.target;
  cam.pan(30, 0, 800);
  EXPECT_GT(glm::length(cam.target - t), 0.0f);
  EXPECT_NEAR(glm::dot(cam.target - t, cam.forward()), 0.0f, 1e-3f);  // in the view plane
  cam.zoom(2);
  EXPECT_LT(cam.distance, d);
}

TEST(Camera, SliceTransformFitsPansAndZoomsAboutTheCursor) {
  SliceViewTransform s;
  s.fit(200, 100, 800, 600);
  const glm::vec2 tl = s.slice_to_screen({0, 0}, 800, 600),
                  br = s.slice_to_screen({200, 100}, 800, 600);
  EXPECT_GE(tl.x, 0);
  EXPECT_LE(br.x, 800);
  EXPECT_LT(tl.y, br.y);  // v grows downwards
  const glm::vec2 p(123, 456);
  const glm::vec2 back = s.slice_to_screen(s.screen_to_slice(p, 800, 600), 800, 600);
  EXPECT_NEAR(back.x, p.x, 1e-3);
  EXPECT_NEAR(back.y, p.y, 1e-3);
  const glm::vec2 under = s.screen_to_slice(p, 800, 600);
  s.zoom_at(3, p.x, p.y, 800, 600);
  const glm::vec2 after = s.screen_to_slice(p, 800, 600);
  EXPECT_NEAR(after.x, under.x, 1e-3);
  EXPECT_NEAR(after.y, under.y, 1e-3);
  // The projection agrees with slice_to_screen.
  const glm::vec4 ndc = s.projection(800, 600) * glm::vec4(50, 20, 0, 1);
  const glm::vec2 px = s.slice_to_screen({50, 20}, 800, 600);
  EXPECT_NEAR((ndc.x + 1) * 400, px.x, 1e-2);
  EXPECT_NEAR((1 - ndc.y) * 300, px.y, 1e-2);
}

TEST(QualitySelection, CountsMatchTheReport) {
  // A perturbed voxel mesh has tets in every bin.
  TetMesh mesh = block_mesh();
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    mesh.vertices[v] +=
        Vec3{0.23 * std::sin(3.1 * v), 0.19 * std::cos(1.7 * v), 0.21 * std::sin(v)};
  const QualityReport q = compute_quality(mesh);
  for (int i = 0; i < 3; ++i) {
    const Measure m = kShewchukMeasures[i];
    const auto values = tet_measures(mesh)[std::size_t(m)];
    for (int b = 0; b < 3; ++b) {
      TetSelection s;
      s.kind = TetSelection::Kind::table1_bin;
      s.measure = m;
      s.index = b;
      const auto sel = select_tets(values, s);
      const double percent =
          100.0 * std::count(sel.begin(), sel.end(), 1) / double(mesh.tets.size());
      EXPECT_NEAR(percent, q.shewchuk[i].bins_percent[b], 1e-9) << measure_key(m) << " bin " << b;
    }
    const auto hist = measure_histogram(values, m, int(q.shewchuk[i].histogram.size()));
    EXPECT_EQ(hist, q.shewchuk[i].histogram) << measure_key(m);
    TetSelection bar;
    bar.kind = TetSelection::Kind::histogram_bar;
    bar.measure = m;
    bar.index = 10;
    bar.range = {measure_scale(m).lo, measure_scale(m).hi};
    bar.bars = 20;
    const auto sel = select_tets(values, bar);
    EXPECT_EQ(std::size_t(std::count(sel.begin(), sel.end(), 1)), hist[10]);
  }
  Measure m;
  EXPECT_TRUE(measure_from_key("min_dihedral_deg", m));
  EXPECT_EQ(m, Measure::MinDihedralDeg);
  EXPECT_FALSE(measure_from_key("beauty", m));
  EXPECT_FALSE(measure_scale(Measure::MaxDihedralDeg).higher_is_better);
  // Colours run from red (bad) to green (good) in the better direction.
  EXPECT_GT(measure_color(Measure::VOverRmc3, 0.0).r, measure_color(Measure::VOverRmc3, 0.5).r);
  EXPECT_GT(measure_color(Measure::MaxDihedralDeg, 170).r,
            measure_color(Measure::MaxDihedralDeg, 75).r);
}
