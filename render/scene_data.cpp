#include "scene_data.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "surface_preview.h"

namespace cvt::render {

std::shared_ptr<const LloydState> make_lloyd_state(const LloydStepper& stepper,
                                                   std::uint64_t generation) {
  auto s = std::make_shared<LloydState>();
  s->generation = generation;
  s->grid = stepper.grid();
  s->sites_world = stepper.sites_world();
  s->sites_local = stepper.sites_local();
  s->history = stepper.history();
  s->resolved = stepper.resolved();
  s->converged = stepper.converged();
  return s;
}

std::shared_ptr<const VolumeLayers> make_volume_layers(
    std::shared_ptr<const PreprocessResult> pre, const Grid& image_grid) {
  auto v = std::make_shared<VolumeLayers>();
  v->grid = pre->object.grid;
  // The crop is a sub-grid (same spacing and direction), so its origin sits on a voxel of the
  // image grid.
  const Vec3 at = image_grid.world_to_index(v->grid.origin);
  for (int a = 0; a < 3; ++a) v->offset[a] = int(std::lround(at[a]));
  v->lfs_bounds = pre->lfs_bounds;
  v->cleanup = pre->cleanup;
  v->object_surface = object_surface_preview(pre->object, pre->boundary.size());
  // Aliasing pointers: each shares ownership of the whole result.
  v->object = std::shared_ptr<const Mask>(pre, &pre->object);
  v->lfs_mm = std::shared_ptr<const Volume<float>>(pre, &pre->lfs_mm);
  v->medial_axis = std::shared_ptr<const Mask>(pre, &pre->medial_axis);
  return v;
}

std::shared_ptr<const MeshLayers> make_mesh_layers(const TetMesh& mesh,
                                                   const std::vector<Vec3>& exterior_poles) {
  auto m = std::make_shared<MeshLayers>();
  m->mesh = mesh;
  m->neighbours = compute_tet_neighbours(m->mesh);
  m->exterior_poles = exterior_poles;
  m->measures = tet_measures(m->mesh);
  m->vertices = mesh.vertices.size();
  m->tets = mesh.tets.size();
  const double inf = std::numeric_limits<double>::infinity();
  m->lo = {inf, inf, inf};
  m->hi = {-inf, -inf, -inf};
  for (const Vec3& p : m->mesh.vertices)
    for (int a = 0; a < 3; ++a) {
      m->lo[a] = std::min(m->lo[a], p[a]);
      m->hi[a] = std::max(m->hi[a], p[a]);
    }
  return m;
}

std::shared_ptr<const MeshMeasures> make_mesh_measures(const TetMesh& mesh) {
  auto m = std::make_shared<MeshMeasures>();
  m->vertices = mesh.vertices.size();
  m->tets = mesh.tets.size();
  m->measures = tet_measures(mesh);
  return m;
}

double stage_seconds(const std::vector<StageRecord>& records, Stage stage) {
  // The latest run: walk back over the records of this stage that follow each other.
  double total = -1;
  bool found = false;
  for (auto it = records.rbegin(); it != records.rend(); ++it) {
    const bool mine = stage_of_record(it->name) == stage;
    if (mine) {
      total = (found ? total : 0.0) + it->wall_s;
      found = true;
      if (it->name == stage_name(stage)) break;  // a whole-stage record stands alone
    } else if (found) {
      break;
    }
  }
  return total;
}

std::shared_ptr<const LloydState> SceneDataBuilder::lloyd_state(const LloydStepper& stepper) {
  return make_lloyd_state(stepper, ++generation_);
}

std::shared_ptr<const SceneData> SceneDataBuilder::update(const Pipeline& pipeline,
                                                          std::shared_ptr<const Image> image) {
  auto s = std::make_shared<SceneData>();
  s->generation = ++generation_;
  const SceneData* prev = last_.get();
  // Stages whose result changed since the last snapshot: their parts are copied again.
  std::array<bool, kStageCount> ran{};
  for (int st = 0; st < kStageCount; ++st) {
    ran[st] = !prev || pipeline.generation(Stage(st)) != seen_[st];
    seen_[st] = pipeline.generation(Stage(st));
  }
  // The previous snapshot holds its image, so the same address is the same image.
  const bool new_image = !prev || prev->image != image;

  s->image = image;
  if (image) s->generations.image = new_image ? s->generation : prev->generations.image;
  if (image && new_image) {
    s->value_range = value_range(*image);
    if (image->integer_valued) s->label_counts = label_histogram(*image);
  } else if (prev) {
    s->value_range = prev->value_range;
    s->label_counts = prev->label_counts;
  }
  s->parameters = pipeline.parameters();
  s->sized_parameters = pipeline.sized_parameters();
  for (int st = 0; st < kStageCount; ++st) s->stale[st] = pipeline.is_stale(Stage(st));
  s->records = pipeline.records();
  s->default_interior_spacing_mm = pipeline.default_interior_spacing_mm();

  // A part is kept from the previous snapshot, with its generation, when its result still
  // exists and its stage did not run again; it is rebuilt, with this snapshot's generation,
  // when it ran; it is dropped (generation 0) when the result is gone (stale).
  auto pick = [&](auto part, std::uint64_t PartGenerations::*generation, bool exists, bool rerun,
                  auto make) {
    if (!exists) return;
    SceneData& out = *s;
    if (prev && prev->*part && !rerun && !new_image) {
      out.*part = prev->*part;
      out.generations.*generation = prev->generations.*generation;
    } else {
      out.*part = make();
      out.generations.*generation = out.generation;
    }
  };
  std::shared_ptr<const PreprocessResult> pre = pipeline.shared_preprocess();
  pick(&SceneData::volumes, &PartGenerations::volumes, pre != nullptr, ran[int(Stage::preprocess)],
       [&] { return make_volume_layers(pre, image->grid()); });
  const SurfaceSamples* surf = pipeline.surface();
  pick(&SceneData::surface_samples, &PartGenerations::surface, surf != nullptr,
       ran[int(Stage::surface)],
       [&] { return std::make_shared<const std::vector<Vec3>>(surf->world); });
  pick(&SceneData::surface_voxel_samples, &PartGenerations::surface, surf != nullptr,
       ran[int(Stage::surface)],
       [&] { return std::make_shared<const std::vector<Vec3>>(surf->voxel_world); });
  // The Lloyd state is small and moves with every step: always copied.
  if (pipeline.lloyd()) s->lloyd = make_lloyd_state(*pipeline.lloyd(), s->generation);
  const ShallowResult* sh = pipeline.shallow();
  pick(&SceneData::shallow, &PartGenerations::shallow, sh != nullptr, ran[int(Stage::shallow)],
       [&] { return std::make_shared<const ShallowResult>(*sh); });
  // The mesh drawn is the pipeline's final one: stage 6's once it ran, else stage 5's.
  const RefinedMesh* generated = pipeline.mesh();
  const OptimizedMesh* optimized = pipeline.optimized();
  pick(&SceneData::mesh, &PartGenerations::mesh, generated != nullptr,
       ran[int(Stage::mesh)] || ran[int(Stage::optimize)],
       [&] { return make_mesh_layers(*pipeline.final_mesh(), generated->exterior_poles); });
  pick(&SceneData::optimization, &PartGenerations::optimization, optimized != nullptr,
       ran[int(Stage::optimize)],
       [&] { return std::make_shared<const OptimizationResult>(optimized->optimization); });
  // The stage-5 mesh's measures: those the last snapshot drew, when it drew that mesh.
  const bool drew_stage5 = prev && prev->mesh && !prev->optimization && !ran[int(Stage::mesh)];
  pick(&SceneData::unoptimized, &PartGenerations::unoptimized, generated && optimized,
       ran[int(Stage::mesh)], [&] {
         return drew_stage5 ? std::shared_ptr<const MeshMeasures>(prev->mesh)
                            : make_mesh_measures(generated->mesh);
       });
  const bool evaluated = ran[int(Stage::evaluate)];
  pick(&SceneData::quality, &PartGenerations::quality, pipeline.quality() != nullptr, evaluated,
       [&] { return std::make_shared<const QualityReport>(*pipeline.quality()); });
  pick(&SceneData::fidelity, &PartGenerations::fidelity, pipeline.fidelity() != nullptr, evaluated,
       [&] { return std::make_shared<const FidelityReport>(*pipeline.fidelity()); });
  last_ = s;
  return s;
}

}  // namespace cvt::render
