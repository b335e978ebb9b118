// The pipeline panel: job progress and controls, the stages with their state, every parameter
// (tooltips from parameter_info and the stage-6 option table), the Lloyd stepping controls with
// the energy and displacement plots, and stage 6's pass-by-pass controls with its history.
#include <imgui.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "parameter_info.h"
#include "ui.h"

namespace cvt::gui {
namespace {

const ImVec4 kDone{0.45f, 0.85f, 0.45f, 1.0f};
const ImVec4 kPending{1.0f, 0.7f, 0.25f, 1.0f};
const ImVec4 kStale{1.0f, 0.4f, 0.4f, 1.0f};

void tooltip(std::string_view key) {
  if (!ImGui::IsItemHovered()) return;
  if (const ParameterInfo* info = find_parameter_info(key))
    ImGui::SetTooltip("%.*s\n(stage: %s)", int(info->tooltip.size()), info->tooltip.data(),
                      info->stage == Stage::count ? "none" : stage_name(info->stage));
}

std::string label_of(std::string_view key) {
  const ParameterInfo* info = find_parameter_info(key);
  return std::string(info ? info->label : key) + "##" + std::string(key);
}

// Each widget reports whether it changed the value, so the panel can time the edit.
bool edit_double(const char* key, double& v, const char* format = "%.4g") {
  const bool changed = ImGui::InputDouble(label_of(key).c_str(), &v, 0.0, 0.0, format);
  tooltip(key);
  return changed;
}
bool edit_int(const char* key, int& v) {
  const bool changed = ImGui::InputInt(label_of(key).c_str(), &v);
  tooltip(key);
  return changed;
}
bool edit_int64(const char* key, std::int64_t& v) {
  long long x = v;
  const bool changed = ImGui::InputScalar(label_of(key).c_str(), ImGuiDataType_S64, &x);
  if (changed) v = x;
  tooltip(key);
  return changed;
}
bool edit_bool(const char* key, bool& v) {
  const bool changed = ImGui::Checkbox(label_of(key).c_str(), &v);
  tooltip(key);
  return changed;
}
bool edit_slider(const char* key, double& v, double lo, double hi) {
  const bool changed =
      ImGui::SliderScalar(label_of(key).c_str(), ImGuiDataType_Double, &v, &lo, &hi, "%.3f");
  tooltip(key);
  return changed;
}

const char* state_text(StageState s) {
  return s == StageState::done ? "done" : s == StageState::pending ? "edited" : "stale";
}
ImVec4 state_color(StageState s) {
  return s == StageState::done ? kDone : s == StageState::pending ? kPending : kStale;
}

// Header of a group of parameters, tinted by the state of its stage.
bool stage_header(const char* title, StageState s) {
  ImGui::PushStyleColor(ImGuiCol_Text, state_color(s));
  const bool open = ImGui::CollapsingHeader(title, ImGuiTreeNodeFlags_DefaultOpen);
  ImGui::PopStyleColor();
  return open;
}

bool edit_object_selection(UiContext& ctx) {
  Parameters& p = ctx.session.edited;
  const render::SceneData* scene = ctx.session.scene();
  bool changed = false;
  if (scene && scene->image && !scene->image->integer_valued) {
    double iso = p.iso.value_or(0.5 * (scene->value_range.min + scene->value_range.max));
    if (edit_double("iso", iso)) p.iso = iso, changed = true;
    changed |= edit_bool("inside_above", p.inside_above);
    return changed;
  }
  bool all = p.labels.empty();
  if (ImGui::Checkbox("all non-zero labels", &all)) {
    changed = true;
    p.labels.clear();
    if (!all && scene)  // start from every label, so unticking removes one
      for (const auto& [label, count] : scene->label_counts)
        if (label != 0) p.labels.push_back(label);
  }
  tooltip("labels");
  if (!scene) return changed;
  for (const auto& [label, count] : scene->label_counts) {
    if (label == 0) continue;
    bool on = all || std::find(p.labels.begin(), p.labels.end(), label) != p.labels.end();
    char text[96];
    std::snprintf(text, sizeof text, "label %lld  (%zu voxels)", (long long)label, count);
    ImGui::BeginDisabled(all);
    if (ImGui::Checkbox(text, &on)) {
      changed = true;
      if (on)
        p.labels.push_back(label);
      else
        p.labels.erase(std::remove(p.labels.begin(), p.labels.end(), label), p.labels.end());
      std::sort(p.labels.begin(), p.labels.end());
    }
    ImGui::EndDisabled();
  }
  return changed;
}

void lloyd_section(UiContext& ctx) {
  Session& s = ctx.session;
  const auto lloyd = s.lloyd();
  const bool busy = s.busy();
  ImGui::BeginDisabled(busy || !s.scene() || !s.scene()->image);
  if (ImGui::Button("Step 1")) s.step_lloyd(1);
  ImGui::SameLine();
  if (ImGui::Button("Step 10")) s.step_lloyd(10);
  ImGui::SameLine();
  if (ImGui::Button("To convergence")) s.step_lloyd(-1);
  ImGui::EndDisabled();
  if (!lloyd) {
    ImGui::TextDisabled("no Lloyd iterations yet");
    return;
  }
  ImGui::Text("iteration %zu, %lld sites, spacing %.3g mm%s", lloyd->history.size(),
              (long long)lloyd->resolved.sites, lloyd->resolved.spacing_mm,
              lloyd->converged ? ", converged" : "");
  if (lloyd->history.empty()) return;
  std::vector<float> energy, displacement;
  for (const IterationStats& it : lloyd->history) {
    energy.push_back(float(it.energy));
    displacement.push_back(float(it.displacement_sum_mm));
  }
  char overlay[64];
  const float width = ImGui::GetContentRegionAvail().x;
  std::snprintf(overlay, sizeof overlay, "energy %.4g", energy.back());
  ImGui::PlotLines("##energy", energy.data(), int(energy.size()), 0, overlay, FLT_MAX, FLT_MAX,
                   ImVec2(width, 70));
  std::snprintf(overlay, sizeof overlay, "sum displacement %.4g mm (eps %.3g)", displacement.back(),
                lloyd->resolved.epsilon_mm);
  ImGui::PlotLines("##displacement", displacement.data(), int(displacement.size()), 0, overlay,
                   0.0f, FLT_MAX, ImVec2(width, 70));
}

// Stage 6: its options, stepping pass by pass, and the per-pass history.
bool optimization_section(UiContext& ctx) {
  Session& s = ctx.session;
  Parameters& p = s.edited;
  bool changed = false;
  bool optimize = p.optimize != "none";
  if (ImGui::Checkbox(label_of("optimize").c_str(), &optimize))
    p.optimize = optimize ? "default" : "none", changed = true;
  tooltip("optimize");
  OptimizationOptions& o = p.optimization;
  for (const OptimizationField& f : optimization_fields()) {
    const std::string label = std::string(f.label) + "##opt_" + std::string(f.key);
    if (f.real) {
      changed |= ImGui::InputDouble(label.c_str(), &(o.*f.real), 0.0, 0.0, "%.4g");
    } else if (f.integer) {
      changed |= ImGui::InputInt(label.c_str(), &(o.*f.integer));
    } else if (f.flag) {
      changed |= ImGui::Checkbox(label.c_str(), &(o.*f.flag));
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("%.*s\n(stage 6, part of mesh generation)", int(f.tooltip.size()),
                        f.tooltip.data());
  }
  if (changed) clamp(o);
  const bool busy = s.busy();
  const render::SceneData* scene = s.scene();
  ImGui::BeginDisabled(busy || !scene || !scene->image);
  if (ImGui::Button("Optimise one pass")) s.step_optimization(1);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("One pass of stage 6 (runs stages 1-5 first if needed; turns it on)");
  ImGui::SameLine();
  if (ImGui::Button("Run to end")) s.step_optimization(-1);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("The remaining passes, one job each: the views follow every pass");
  ImGui::EndDisabled();
  ImGui::SameLine();
  ImGui::BeginDisabled(!busy);
  if (ImGui::Button("Cancel##optimisation")) s.cancel();
  ImGui::EndDisabled();
  const OptimizationResult* r = scene ? scene->optimization.get() : nullptr;
  if (!r || r->history.empty()) {
    ImGui::TextDisabled("no optimisation pass yet");
    return changed;
  }
  const int passes = int(r->history.size()) - 1;
  const bool finished = scene->parameters.optimize == "default" && !scene->stale[int(Stage::mesh)];
  ImGui::Text("pass %d of at most %d%s, %.2f s; %zu inserted, %zu corners removed", passes,
              scene->parameters.optimization.max_passes, finished ? ", finished" : "", r->wall_s,
              r->inserted_vertices, r->corner_removals);
  ImGui::Text("boundary: within %.3g mm of the surface (before %.3g mm)",
              r->surface_distance_after_mm, r->surface_distance_before_mm);
  std::vector<float> min_dihedral, bad;
  for (const PassStats& ps : r->history)
    if (ps.has_statistics) {
      min_dihedral.push_back(float(ps.min_dihedral_deg));
      bad.push_back(float(ps.below_10));
    }
  if (min_dihedral.empty()) return changed;
  const float width = ImGui::GetContentRegionAvail().x;
  char overlay[80];
  std::snprintf(overlay, sizeof overlay, "min dihedral %.2f deg (pass 0: %.2f)",
                min_dihedral.back(), min_dihedral.front());
  ImGui::PlotLines("##min_dihedral", min_dihedral.data(), int(min_dihedral.size()), 0, overlay,
                   0.0f, FLT_MAX, ImVec2(width, 60));
  std::snprintf(overlay, sizeof overlay, "tets below 10 deg: %.0f (pass 0: %.0f)", bad.back(),
                bad.front());
  ImGui::PlotLines("##below_10", bad.data(), int(bad.size()), 0, overlay, 0.0f, FLT_MAX,
                   ImVec2(width, 60));
  return changed;
}

}  // namespace

void draw_pipeline_panel(UiContext& ctx) {
  if (!ctx.ui.show_pipeline) return;
  const Rect& r = ctx.ui.pipeline_panel;
  ImGui::SetNextWindowPos(ImVec2(r.x, r.y));
  ImGui::SetNextWindowSize(ImVec2(r.w, r.h));
  if (!ImGui::Begin(
          "Pipeline", &ctx.ui.show_pipeline,
          ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse)) {
    ImGui::End();
    return;
  }
  Session& s = ctx.session;
  const render::SceneData* scene = s.scene();
  const bool busy = s.busy();
  const bool has_image = scene && scene->image;
  if (has_image) {
    const Grid& g = scene->image->grid();
    ImGui::TextWrapped("%s", s.image_path.c_str());
    ImGui::Text("%d x %d x %d voxels, %.3g x %.3g x %.3g mm", g.dims[0], g.dims[1], g.dims[2],
                g.spacing.x, g.spacing.y, g.spacing.z);
  } else {
    ImGui::TextDisabled("no image: File > Open, or drop a file on the window");
  }
  const auto states = s.stage_states();
  const bool any_not_done = std::any_of(states.begin(), states.end(),
                                        [](StageState st) { return st != StageState::done; });

  ImGui::BeginDisabled(busy || !has_image);
  if (ImGui::Button("Run all")) s.run_all();
  ImGui::SameLine();
  if (ImGui::Button("Run one stage")) s.run_next_stage();
  ImGui::SameLine();
  const bool highlight_rerun = s.edits_pending();
  if (highlight_rerun) ImGui::PushStyleColor(ImGuiCol_Button, ImVec4(0.75f, 0.45f, 0.1f, 1.0f));
  if (ImGui::Button("Re-run stale")) s.rerun_stale();
  if (highlight_rerun) ImGui::PopStyleColor();
  ImGui::EndDisabled();
  ImGui::SameLine();
  ImGui::Checkbox("auto", &s.auto_rerun);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Re-run the stale stages by themselves after a parameter change");

  // The stages and their state.
  if (ImGui::BeginTable("stages", 3, ImGuiTableFlags_SizingStretchProp)) {
    for (int st = 0; st < kStageCount; ++st) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::Text("%d %s", st + 1, stage_name(Stage(st)));
      ImGui::TableNextColumn();
      ImGui::TextColored(state_color(states[st]), "%s", state_text(states[st]));
      ImGui::TableNextColumn();
      if (const double t = scene ? render::stage_seconds(scene->records, Stage(st)) : -1; t >= 0)
        ImGui::Text("%.2f s", t);
    }
    ImGui::EndTable();
  }
  if (!any_not_done && has_image) ImGui::TextColored(kDone, "all stages done");

  try {
    validate(s.edited);
  } catch (const std::exception& e) {
    ImGui::PushStyleColor(ImGuiCol_Text, kStale);
    ImGui::TextWrapped("%s", e.what());
    ImGui::PopStyleColor();
  }

  Parameters& p = s.edited;
  bool changed = false;
  ImGui::PushItemWidth(120);
  if (stage_header("1 Preprocess", states[0])) {
    changed |= edit_object_selection(ctx);
    changed |= edit_int("margin_voxels", p.margin_voxels);
    changed |= edit_bool("remove_small_components", p.remove_small_components);
    changed |= edit_double("min_component_fraction", p.min_component_fraction);
    changed |= edit_bool("fill_cavities", p.fill_cavities);
    changed |= edit_double("smoothing_sigma_mm", p.smoothing_sigma_mm);
    changed |= edit_double("medial_min_separation_mm", p.medial_min_separation_mm);
    changed |= edit_double("medial_min_angle_deg", p.medial_min_angle_deg);
    changed |= edit_double("lfs_min_mm", p.lfs_min_mm);
    changed |= edit_double("lfs_max_mm", p.lfs_max_mm);
  }
  if (stage_header("2 Surface sampling", states[1])) {
    changed |= edit_slider("r", p.r, 0.05, 0.95);
    changed |= edit_double("sigma_surface_mm", p.sigma_surface_mm);
    changed |= edit_bool("project_samples", p.project_samples);
  }
  if (stage_header("3 CVT sampling", states[2])) {
    changed |= edit_double("sigma_density_mm", p.sigma_density_mm);
    changed |= edit_double("interior_spacing_mm", p.interior_spacing_mm);
    if (scene && scene->default_interior_spacing_mm > 0 && p.interior_spacing_mm == 0)
      ImGui::TextDisabled("auto spacing: %.3g mm", scene->default_interior_spacing_mm);
    changed |= edit_int64("interior_points", p.interior_points);
    changed |= edit_double("epsilon_mm", p.epsilon_mm);
    changed |= edit_int("max_iterations", p.max_iterations);
    long long seed = (long long)p.seed;
    if (ImGui::InputScalar(label_of("seed").c_str(), ImGuiDataType_S64, &seed))
      p.seed = std::uint64_t(std::max(0LL, seed)), changed = true;
    tooltip("seed");
    lloyd_section(ctx);
  }
  if (stage_header("5 Mesh generation", states[int(Stage::mesh)])) {
    changed |= edit_int("fidelity_rounds", p.fidelity_rounds);
    changed |= edit_double("fidelity_tolerance_mm", p.fidelity_tolerance_mm);
  }
  if (stage_header("6 Optimisation (in mesh generation)", states[int(Stage::mesh)]))
    changed |= optimization_section(ctx);
  if (ImGui::CollapsingHeader("Other (threads, guards)")) {
    changed |= edit_int("threads", p.threads);
    changed |= edit_int64("max_points", p.max_points);
    changed |= edit_double("max_memory_mb", p.max_memory_mb);
  }
  ImGui::PopItemWidth();
  if (changed) s.parameters_edited(ctx.ui.now_s);
  ImGui::End();
}

}  // namespace cvt::gui
