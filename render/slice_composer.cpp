#include "slice_composer.h"

#include <utility>

namespace cvt::render {

const std::vector<Vec3>* interior_points(const SceneData& scene, const LloydState* lloyd) {
  if (scene.shallow && lloyd && scene.lloyd && lloyd->generation == scene.lloyd->generation)
    return &scene.shallow->kept_world;
  return lloyd ? &lloyd->sites_world : nullptr;
}

SliceView compose_slice_view(const SliceRequest& r, VoronoiCache* cache) {
  const SceneData& scene = *r.scene;
  const Grid& grid = scene.image->grid();
  const VolumeLayers* vol = scene.volumes.get();
  const LloydState* lloyd = r.lloyd.get();
  VoronoiCache local;
  VoronoiCache& c = cache ? *cache : local;
  const std::vector<std::int32_t>* voronoi = nullptr;
  if (r.overlays.voronoi && lloyd && vol) {
    if (c.lloyd != lloyd->generation || c.volumes != scene.generations.volumes ||
        c.axis != r.axis || c.index != r.index || lloyd->generation == 0) {
      c.labels = voronoi_slice_labels(*lloyd, *vol, grid, r.axis, r.index);
      c.lloyd = lloyd->generation;
      c.volumes = scene.generations.volumes;
      c.axis = r.axis;
      c.index = r.index;
    }
    voronoi = &c.labels;
  }
  SliceView out;
  out.image_generation = scene.generations.image;
  out.axis = r.axis;
  out.image =
      compose_slice(*scene.image, vol, voronoi, r.axis, r.index, r.overlays, r.window_level);

  const Overlays& o = r.overlays;
  const double half = 0.5;  // voxels: the points whose nearest slice this is
  auto add = [&](const std::vector<Vec3>& points, Rgba8 color) {
    append_points_near_slice(points, grid, r.axis, r.index, half, color, out.points);
  };
  if (o.voxel_samples && scene.surface_voxel_samples)
    add(*scene.surface_voxel_samples, kVoxelSampleColor);
  if (o.samples && scene.surface_samples) add(*scene.surface_samples, kSampleColor);
  if (const std::vector<Vec3>* interior = interior_points(scene, lloyd); o.interior && interior)
    add(*interior, kInteriorColor);
  if (o.shallow && scene.shallow) add(scene.shallow->removed_world, kShallowColor);
  if (o.poles && scene.mesh) add(scene.mesh->exterior_poles, kPoleColor);

  const auto [ua, va] = slice_plane_axes(r.axis);
  const double us[4] = {-0.5, grid.dims[ua] - 0.5, grid.dims[ua] - 0.5, -0.5};
  const double vs[4] = {-0.5, -0.5, grid.dims[va] - 0.5, grid.dims[va] - 0.5};
  for (int k = 0; k < 4; ++k) {
    Vec3 idx;
    idx[r.axis] = r.index;
    idx[ua] = us[k];
    idx[va] = vs[k];
    out.plane_corners[k] = grid.index_to_world(idx);
  }
  return out;
}

AsyncSliceComposer::AsyncSliceComposer() : thread_([this] { thread_main(); }) {}

AsyncSliceComposer::~AsyncSliceComposer() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void AsyncSliceComposer::request(SliceRequest request) {
  {
    std::lock_guard lock(mutex_);
    pending_ = std::move(request);
  }
  wake_.notify_one();
}

std::optional<SliceView> AsyncSliceComposer::take() {
  std::lock_guard lock(mutex_);
  return std::exchange(done_, std::nullopt);
}

bool AsyncSliceComposer::busy() const {
  std::lock_guard lock(mutex_);
  return pending_ || working_ || done_;
}

void AsyncSliceComposer::thread_main() {
  for (;;) {
    SliceRequest request;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || pending_; });
      if (stop_) return;
      request = std::move(*pending_);
      pending_.reset();
      working_ = true;
    }
    SliceView view = compose_slice_view(request, &cache_);
    std::lock_guard lock(mutex_);
    working_ = false;
    // A newer request waiting makes this picture outdated; it is shown anyway (it is newer
    // than what is on screen) and the newer one follows.
    done_ = std::move(view);
  }
}

}  // namespace cvt::render
