// The viewer's GL-free data preparation (render/): slice pictures (window/level, outline,
// Voronoi cells), points near a slice, the surface preview and the pipeline snapshots. No
// window or GL context.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <thread>

#include "phantoms.h"
#include "scene_data.h"
#include "slice_composer.h"
#include "slice_image.h"
#include "surface_preview.h"

using namespace cvt;
using namespace cvt::render;

namespace {

// A 6 × 5 × 3 image (label 7 in a 3 × 2 block of slice k = 1) with volume layers on a crop
// that starts at image voxel (1, 1, 0).
struct SliceFixture {
  Image image;
  VolumeLayers vol;
  SliceFixture() {
    Grid g;
    g.dims = {6, 5, 3};
    g.spacing = {0.5, 0.8, 2.0};
    g.origin = {10, 20, 30};
    image.voxels = Volume<float>(g, 0.0f);
    for (int j = 2; j < 4; ++j)
      for (int i = 2; i < 5; ++i) image.voxels.at(i, j, 1) = 7;
    vol.grid = g.sub_grid({1, 1, 0}, {5, 4, 3});
    vol.offset = {1, 1, 0};
    auto object = std::make_shared<Mask>(vol.grid, 0);
    for (int j = 1; j < 3; ++j)
      for (int i = 1; i < 4; ++i) object->at(i, j, 1) = 1;
    vol.object = object;
    vol.lfs_mm = std::make_shared<Volume<float>>(vol.grid, 2.0f);
    vol.medial_axis = std::make_shared<Mask>(vol.grid, 0);
    vol.lfs_bounds = {1.0, 3.0};
  }
};

}  // namespace

TEST(SliceImage, GreyWindowOutlineAndSize) {
  SliceFixture f;
  Overlays none{false, false, false, false, false, false, false, false};
  const SliceImage grey = compose_slice(f.image, &f.vol, nullptr, 2, 1, none, {7, 3.5}, 1);
  ASSERT_EQ(grey.width, 6);
  ASSERT_EQ(grey.height, 5);
  EXPECT_DOUBLE_EQ(grey.pixel_mm[0], 0.5);
  EXPECT_DOUBLE_EQ(grey.pixel_mm[1], 0.8);
  EXPECT_EQ(grey.pixels[0].r, 0);            // value 0 at the window's bottom
  EXPECT_EQ(grey.pixels[2 * 6 + 2].r, 255);  // value 7 at its top
  // Four pixels per voxel: the object outline runs along the voxel edges, one pixel wide on
  // each side of the boundary, so the object's inner pixels keep the tint.
  Overlays object = none;
  object.object = true;
  const SliceImage up = compose_slice(f.image, &f.vol, nullptr, 2, 1, object, {7, 3.5}, 4);
  ASSERT_EQ(up.width, 24);
  ASSERT_EQ(up.upsample, 4);
  EXPECT_DOUBLE_EQ(up.pixel_mm[0], 0.125);
  const auto px = [&](int x, int y) { return up.pixels[std::size_t(y) * up.width + x]; };
  const Rgba8 rim = px(8, 9), inner = px(10, 10), outside = px(2, 2);
  EXPECT_NE(rim, inner);  // voxel (2,2) is at the object's corner: its first pixel is outline
  EXPECT_EQ(outside, (Rgba8{0, 0, 0, 255}));
  EXPECT_GT(inner.g, inner.r);  // green tint over white
  // A slice outside the crop has no overlays.
  EXPECT_EQ(compose_slice(f.image, &f.vol, nullptr, 2, 0, object, {7, 3.5}, 1).pixels[7],
            (Rgba8{0, 0, 0, 255}));
}

TEST(SliceImage, VoronoiCellsAndBorders) {
  SliceFixture f;
  LloydState lloyd;
  lloyd.grid = f.vol.grid;
  // Two sites: left and right part of the object row (local frame: spacing ⊙ crop index).
  lloyd.sites_local = {{1.0 * 0.5, 1.5 * 0.8, 1 * 2.0}, {3.0 * 0.5, 1.5 * 0.8, 1 * 2.0}};
  const auto labels = voronoi_slice_labels(lloyd, f.vol, f.image.grid(), 2, 1);
  ASSERT_EQ(labels.size(), 30u);
  EXPECT_EQ(labels[0], -1);         // outside the object
  EXPECT_EQ(labels[2 * 6 + 2], 0);  // image voxel (2,2) = crop (1,1): nearest site 0
  EXPECT_EQ(labels[2 * 6 + 4], 1);  // image voxel (4,2) = crop (3,1): site 1
  Overlays cells{false, false, false, false, false, false, false, true};
  const SliceImage img = compose_slice(f.image, &f.vol, &labels, 2, 1, cells, {7, 3.5}, 4);
  std::set<std::array<int, 3>> colours;
  for (const Rgba8& p : img.pixels) colours.insert({p.r, p.g, p.b});
  EXPECT_GE(colours.size(), 4u);  // background, two cells, borders
  // Voxel (2,2)'s centre pixel is cell colour, not border.
  const Rgba8 centre = img.pixels[std::size_t(2 * 4 + 1) * img.width + 2 * 4 + 1];
  EXPECT_NE(centre, img.pixels[std::size_t(2 * 4) * img.width + 2 * 4]);
}

TEST(SliceImage, PointsNearTheSlice) {
  SliceFixture f;
  const Grid& g = f.image.grid();
  std::vector<SlicePoint> out;
  append_points_near_slice({g.index_to_world({2, 3, 1.2}), g.index_to_world({2, 3, 1.8})}, g, 2, 1,
                           0.5, kSampleColor, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].u_mm, 2 * 0.5, 1e-5);  // floats: what the GPU gets
  EXPECT_NEAR(out[0].v_mm, 3 * 0.8, 1e-5);
  EXPECT_EQ(slice_plane_axes(0), (std::array<int, 2>{1, 2}));
  EXPECT_EQ(slice_plane_axes(1), (std::array<int, 2>{0, 2}));
  Overlays o;
  EXPECT_TRUE(set_overlay(o, "voronoi", true));
  EXPECT_TRUE(o.voronoi);
  EXPECT_FALSE(set_overlay(o, "nonsense", true));
  EXPECT_FALSE(o.voxel_samples);
  EXPECT_TRUE(set_overlay(o, "voxel-samples", true));
  EXPECT_TRUE(o.voxel_samples);
  EXPECT_GE(slice_upsample(438, 353), 2);
  EXPECT_EQ(slice_upsample(4000, 10), 1);
}

TEST(SurfacePreview, CoarsensBigSurfacesAndKeepsTheShape) {
  const Phantom p = sphere_phantom({3, -2, 5}, 10.0);
  const Image img = rasterize(p, grid_around(p, {0.5, 0.5, 0.5}, rotation_matrix({0, 0, 1}, 0)));
  Mask mask(img.grid(), 0);
  for (std::size_t i = 0; i < mask.size(); ++i) mask.data[i] = img.voxels.data[i] > 0;
  const Mask same = display_mask(mask, 1000, 1000000);
  EXPECT_EQ(same.grid.dims, mask.grid.dims);
  const Mask coarse = display_mask(mask, 20000, 5000);
  EXPECT_LT(coarse.grid.dims[0], mask.grid.dims[0]);
  EXPECT_GT(coarse.grid.spacing.x, mask.grid.spacing.x);
  const TriangleSurface s = object_surface_preview(mask, 20000, 5000);
  ASSERT_FALSE(s.vertices.empty());
  // Smoothing neither shrinks nor moves it much: every vertex stays near the sphere.
  for (const Vec3& v : s.vertices) EXPECT_NEAR(distance(v, p.center), 10.0, 1.6);
  EXPECT_TRUE(surface_topology(s.triangles, s.vertices.size()).closed_manifold);
}

TEST(SceneData, SnapshotsShareWhatDidNotChange) {
  const Phantom p = torus_phantom({4, -3, 2}, 9.0, 3.5);
  auto image = std::make_shared<const Image>(
      rasterize(p, grid_around(p, {0.7, 0.8, 1.0}, rotation_matrix({1, 0, 1}, 0.3))));
  Pipeline pipe;
  pipe.set_image(image);
  SceneDataBuilder builder;
  const auto empty = builder.update(pipe, image);
  EXPECT_EQ(empty->volumes, nullptr);
  EXPECT_EQ(empty->generation, 1u);
  EXPECT_EQ(empty->generations.image, 1u);
  EXPECT_EQ(empty->generations.volumes, 0u);  // no such part
  EXPECT_EQ(empty->label_counts.at(1),
            std::size_t(std::count(image->voxels.data.begin(), image->voxels.data.end(), 1.0f)));
  pipe.run_all();
  const auto full = builder.update(pipe, image);
  ASSERT_NE(full->volumes, nullptr);
  ASSERT_NE(full->mesh, nullptr);
  ASSERT_NE(full->quality, nullptr);
  EXPECT_EQ(full->mesh->mesh.tets.size(), pipe.final_mesh()->tets.size());
  EXPECT_EQ(full->mesh->measures[0].size(), full->mesh->mesh.tets.size());
  for (int s = 0; s < kStageCount; ++s) EXPECT_FALSE(full->stale[s]);
  // Every part is new except the image; the Lloyd state is numbered with its snapshot.
  EXPECT_EQ(full->generation, 2u);
  EXPECT_EQ(full->generations.image, 1u);
  EXPECT_EQ(full->generations.volumes, 2u);
  EXPECT_EQ(full->generations.mesh, 2u);
  EXPECT_EQ(full->generations.quality, 2u);
  ASSERT_NE(full->lloyd, nullptr);
  EXPECT_EQ(full->lloyd->generation, 2u);
  EXPECT_GE(stage_seconds(full->records, Stage::evaluate), 0.0);
  EXPECT_GE(stage_seconds(full->records, Stage::cvt), 0.0);
  // Nothing ran: every part is shared.
  const auto again = builder.update(pipe, image);
  EXPECT_EQ(again->volumes, full->volumes);
  EXPECT_EQ(again->mesh, full->mesh);
  EXPECT_EQ(again->quality, full->quality);
  EXPECT_EQ(again->generation, 3u);
  EXPECT_EQ(again->generations, full->generations);
  // A live Lloyd state between snapshots takes the next number.
  EXPECT_EQ(builder.lloyd_state(*pipe.lloyd())->generation, 4u);
  // A new r: stage 1 is kept, stage 2 is new, the rest is gone until it runs again.
  Parameters params = pipe.parameters();
  params.r = 0.3;
  pipe.set_parameters(params);
  pipe.run_through(Stage::surface);
  const auto partial = builder.update(pipe, image);
  EXPECT_EQ(partial->volumes, full->volumes);
  ASSERT_NE(partial->surface_samples, nullptr);
  EXPECT_NE(partial->surface_samples, full->surface_samples);
  EXPECT_EQ(partial->generations.volumes, full->generations.volumes);
  EXPECT_EQ(partial->generations.surface, partial->generation);
  EXPECT_EQ(partial->generations.mesh, 0u);
  // Both positions of B travel, so the slice view can show them side by side.
  ASSERT_NE(partial->surface_voxel_samples, nullptr);
  EXPECT_EQ(partial->surface_voxel_samples->size(), partial->surface_samples->size());
  EXPECT_EQ(*partial->surface_voxel_samples, pipe.surface()->voxel_world);
  EXPECT_EQ(partial->mesh, nullptr);
  EXPECT_TRUE(partial->stale[int(Stage::mesh)]);
  // Re-running evaluation is noticed even though it records its parts by their own names.
  pipe.run_all();
  const auto rerun = builder.update(pipe, image);
  ASSERT_NE(rerun->quality, nullptr);
  EXPECT_NE(rerun->quality, full->quality);
  EXPECT_EQ(rerun->generations.quality, rerun->generation);
  EXPECT_EQ(stage_of_record("fidelity"), Stage::evaluate);
}

// The viewer tells what the clean-up did (a cavity kept is a hole in the mesh): the snapshot
// carries stage 1's report.
TEST(SceneData, VolumesCarryTheCleanup) {
  const Phantom p = hollow_sphere_phantom({0, 0, 0}, 4.0, 8.0);
  auto image = std::make_shared<const Image>(
      rasterize(p, grid_around(p, {1, 1, 1}, rotation_matrix({0, 0, 1}, 0))));
  Pipeline pipe;
  pipe.set_image(image);
  pipe.run_through(Stage::preprocess);
  SceneDataBuilder builder;
  const auto s = builder.update(pipe, image);
  ASSERT_NE(s->volumes, nullptr);
  EXPECT_EQ(s->volumes->cleanup.cavities_kept, 1);
  EXPECT_EQ(s->volumes->cleanup.voxels_kept, pipe.preprocess()->cleanup.voxels_kept);
  EXPECT_GT(s->volumes->cleanup.voxels_kept, 0u);
}

TEST(SliceComposer, ComposesOffThreadNewestFirst) {
  SliceFixture f;
  auto scene = std::make_shared<SceneData>();
  scene->image = std::make_shared<const Image>(f.image);
  scene->generations.image = 7;
  scene->volumes = std::make_shared<const VolumeLayers>(f.vol);
  const Grid& g = f.image.grid();
  scene->surface_samples =
      std::make_shared<const std::vector<Vec3>>(std::vector<Vec3>{g.index_to_world({3, 2, 1})});
  SliceRequest r;
  r.scene = scene;
  r.axis = 2;
  r.index = 1;
  r.window_level = {7, 3.5};
  // Synchronously: the picture, the sample on this slice, the plane at the voxel edges.
  const SliceView direct = compose_slice_view(r);
  EXPECT_EQ(direct.points.size(), 1u);
  EXPECT_EQ(direct.image_generation, 7u);
  const Vec3 corner = g.index_to_world({-0.5, -0.5, 1});
  EXPECT_NEAR(distance(direct.plane_corners[0], corner), 0.0, 1e-9);
  // Asynchronously, two requests in a row: whatever arrives last is the newest one.
  AsyncSliceComposer composer;
  composer.request(r);
  r.index = 2;
  composer.request(r);
  std::optional<SliceView> last;
  for (int i = 0; i < 2000 && composer.busy(); ++i) {
    if (auto v = composer.take()) last = std::move(v);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_FALSE(composer.busy());
  ASSERT_TRUE(last);
  EXPECT_TRUE(last->points.empty());  // the sample is on slice 1, not 2
  EXPECT_NEAR(last->plane_corners[0].z, g.index_to_world({0, 0, 2}).z, 1e-9);
}
