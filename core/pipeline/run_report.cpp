#include "pipeline/run_report.h"

#include <nlohmann/json.hpp>

#include "base/memory.h"
#include "optimize/mesh_optimization.h"
#include "pipeline/preset.h"

namespace cvt {
namespace {

nlohmann::json transform_json(const NiftiTransform& t) {
  nlohmann::json matrix = nullptr;
  if (t.set()) {
    matrix = nlohmann::json::array();
    for (int r = 0; r < 4; ++r)
      matrix.push_back({t.index_to_ras[4 * r], t.index_to_ras[4 * r + 1], t.index_to_ras[4 * r + 2],
                        t.index_to_ras[4 * r + 3]});
  }
  return {{"code", t.code}, {"matrix", matrix}};
}

}  // namespace

nlohmann::json image_json(const Image& image) {
  const Grid& g = image.grid();
  nlohmann::json j;
  j["file"] = image.source;
  j["dims"] = {g.dims[0], g.dims[1], g.dims[2]};
  j["spacing"] = {g.spacing.x, g.spacing.y, g.spacing.z};
  j["origin"] = {g.origin.x, g.origin.y, g.origin.z};
  j["direction"] = g.direction;
  if (image.nifti)
    j["nifti"] = {{"frame", image.frame},
                  {"qform", transform_json(image.nifti->qform)},
                  {"sform", transform_json(image.nifti->sform)}};
  j["warnings"] = image.warnings;
  return j;
}

nlohmann::json run_report(const Pipeline& pipe) {
  using nlohmann::json;
  json j;
  j["parameters"] = to_json(pipe.parameters());
  if (pipe.parameters().target_vertices > 0) {
    const Parameters sized = pipe.sized_parameters();
    j["vertex_budget"] = {{"target_vertices", sized.target_vertices},
                          {"r", sized.r},
                          {"interior_points", sized.interior_points}};
  }
  json stages = json::array();
  for (const StageRecord& r : pipe.records())
    stages.push_back({{"name", r.name}, {"wall_s", r.wall_s}, {"peak_rss_mb", r.peak_rss_mb}});
  j["stages"] = stages;
  j["peak_rss_mb"] = double(peak_rss_bytes()) / (1024.0 * 1024.0);
  if (const PreprocessResult* pre = pipe.preprocess()) {
    json steps = json::array();
    for (const StepTime& s : pre->steps) steps.push_back({{"name", s.name}, {"wall_s", s.wall_s}});
    j["preprocess"] = {{"steps", steps},
                       {"crop_dims", pre->object.grid.dims},
                       {"boundary_voxels", pre->boundary.size()},
                       {"smoothing_sigma_mm", pre->smoothing_sigma_mm},
                       {"volume_to_area_mm", pre->volume_to_area_mm},
                       {"sizing_unit_mm", pre->sizing_unit_mm},
                       {"medial_min_separation_mm", pre->medial_min_separation_mm},
                       {"lfs_min_mm", pre->lfs_bounds.min_mm},
                       {"lfs_max_mm", pre->lfs_bounds.max_mm},
                       {"components", pre->cleanup.components},
                       {"components_removed", pre->cleanup.components_removed},
                       {"cavities_filled", pre->cleanup.cavities_filled},
                       {"cavity_voxels_filled", pre->cleanup.voxels_filled},
                       {"cavities_kept", pre->cleanup.cavities_kept},
                       {"cavity_voxels_kept", pre->cleanup.voxels_kept}};
  }
  if (const LloydStepper* lloyd = pipe.lloyd()) {
    json its = json::array();
    for (const IterationStats& s : lloyd->history())
      its.push_back({{"energy", s.energy},
                     {"displacement_sum_mm", s.displacement_sum_mm},
                     {"displacement_mean_mm", s.displacement_mean_mm},
                     {"displacement_max_mm", s.displacement_max_mm},
                     {"wall_s", s.wall_s}});
    const CvtResolved& r = lloyd->resolved();
    j["lloyd"] = {{"iterations", its},
                  {"converged", lloyd->converged()},
                  {"sites", r.sites},
                  {"spacing_mm", r.spacing_mm},
                  {"sigma_density_mm", r.sigma_density_mm},
                  {"epsilon_mm", r.epsilon_mm}};
  }
  if (const SurfaceSamples* s = pipe.surface())
    j["surface_sampling"] = {{"r", pipe.sized_parameters().r},
                             {"surface_lfs_max_mm", s->surface_lfs_max_mm},
                             {"projection_failures", s->projection_failures}};
  json counts = json::object();
  if (const SurfaceSamples* s = pipe.surface()) counts["surface_samples"] = s->world.size();
  if (const LloydStepper* l = pipe.lloyd()) counts["interior_samples"] = l->sites_world().size();
  if (const ShallowResult* s = pipe.shallow()) counts["shallow_removed"] = s->removed_world.size();
  if (const RefinedMesh* m = pipe.mesh()) {
    counts["exterior_poles"] = m->exterior_poles.size();
    counts["interior_poles"] = m->interior_poles.size();
    counts["near_surface_poles"] = m->near_surface_poles;
    counts["vertices"] = pipe.final_mesh()->vertices.size();
    counts["tets"] = pipe.final_mesh()->tets.size();
    counts["delaunay_tets"] = m->delaunay_tets;
    counts["removed_by_poles"] = m->removed_by_poles;
    counts["removed_by_centroid"] = m->removed_by_centroid;
    counts["unused_samples"] = m->unused_samples;
    counts["pinched_samples_removed"] = m->pinched_samples.size();
    counts["removed_by_repair"] = m->removed_by_repair.size();
    counts["removed_small_components"] = m->removed_small_components;
    counts["repair_passes"] = m->repair.passes;
    counts["flat_removed"] = m->repair.flat_removed;
    counts["refinement_added_samples"] = m->added_surface_samples.size();
    counts["refinement_dropped_interior"] = m->dropped_interior_samples.size();
    json rounds = json::array();
    for (const FidelityRefinementRound& r : m->refinement)
      rounds.push_back({{"disagreeing_voxels", r.disagreeing_voxels},
                        {"deep_boundary_samples", r.deep_boundary_samples},
                        {"added_samples", r.added_samples},
                        {"dropped_interior", r.dropped_interior},
                        {"boundary_euler", r.boundary_euler},
                        {"accepted", r.accepted},
                        {"returned", r.returned}});
    j["refinement"] = rounds;
  }
  j["counts"] = counts;
  if (const OptimizedMesh* o = pipe.optimized()) j["optimization"] = to_json(o->optimization);
  if (const QualityReport* q = pipe.quality()) j["quality"] = to_json(*q);
  if (const FidelityReport* f = pipe.fidelity()) j["fidelity"] = to_json(*f);
  return j;
}

}  // namespace cvt
