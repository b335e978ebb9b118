// The slice view's picture and points, composed on a thread of their own: a Lloyd iteration or
// a slider move asks for a new picture, and the UI thread keeps drawing the previous one until
// it is ready (composing the liver's upsampled slice with its Voronoi cells takes tens of ms).
// The newest request wins; older unfinished ones are dropped. GL-free.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "scene_data.h"
#include "slice_image.h"

namespace cvt::render {

struct SliceRequest {
  std::shared_ptr<const SceneData> scene;   // with an image
  std::shared_ptr<const LloydState> lloyd;  // the sites to show (live, or the snapshot's)
  int axis = 2, index = 0;                  // image slice
  Overlays overlays;
  WindowLevel window_level;
};

struct SliceView {
  SliceImage image;
  std::vector<SlicePoint> points;
  std::array<Vec3, 4> plane_corners;  // the slice's rectangle in the 3D scene (world mm):
                                      // (u0,v0), (u1,v0), (u1,v1), (u0,v1) at the voxel edges
  std::uint64_t image_generation = 0;  // of the image it shows (to refit on a new one)
  int axis = 2;
};

// Interior samples I: without the shallow ones once stage 4 ran on the sites shown, else the
// sites of `lloyd` (a live state during a job is newer than the snapshot's shallow points).
const std::vector<Vec3>* interior_points(const SceneData& scene, const LloydState* lloyd);

// Everything at once, on the calling thread. `voronoi_cache` (may be null) keeps the labels
// of the last (sites, slice) between calls.
struct VoronoiCache {
  std::uint64_t lloyd = 0, volumes = 0;  // generations of the labels' sites and crop
  int axis = -1, index = -1;
  std::vector<std::int32_t> labels;
};
SliceView compose_slice_view(const SliceRequest& request, VoronoiCache* voronoi_cache = nullptr);

class AsyncSliceComposer {
 public:
  AsyncSliceComposer();
  ~AsyncSliceComposer();
  AsyncSliceComposer(const AsyncSliceComposer&) = delete;
  AsyncSliceComposer& operator=(const AsyncSliceComposer&) = delete;

  void request(SliceRequest request);
  // The newest finished picture not taken yet.
  std::optional<SliceView> take();
  // True while a requested picture is not finished or not taken.
  bool busy() const;

 private:
  void thread_main();
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<SliceRequest> pending_;
  std::optional<SliceView> done_;
  bool working_ = false, stop_ = false;
  VoronoiCache cache_;  // composer thread only
  std::thread thread_;  // last: starts after the members above exist
};

}  // namespace cvt::render
