// The pipeline panel: job progress and controls, the stages with their state, every parameter
// of the registry (a widget by its type, its label, unit, range and tooltip), the Lloyd
// stepping controls with the energy and displacement plots, and stage 6's pass-by-pass controls
// with its history.
#include <imgui.h>

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <cstdio>
#include <string>
#include <vector>

#include "parameter_widgets.h"
#include "pipeline/parameter_registry.h"
#include "ui.h"

namespace cvt::gui {
namespace {

const ImVec4 kDone{0.45f, 0.85f, 0.45f, 1.0f};
const ImVec4 kPending{1.0f, 0.7f, 0.25f, 1.0f};
const ImVec4 kStale{1.0f, 0.4f, 0.4f, 1.0f};

const ParameterSpec& spec_of(std::string_view key) {
  const ParameterSpec* spec = find_parameter("", key);
  if (!spec) throw std::logic_error("no parameter " + std::string(key) + " in the registry");
  return *spec;
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
    if (ImGui::InputDouble(label_of(spec_of("iso")).c_str(), &iso, 0.0, 0.0, "%.4g"))
      p.iso = iso, changed = true;
    tooltip(spec_of("iso"));
    changed |= edit_parameter(spec_of("inside_above"), p);
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
  tooltip(spec_of("labels"));
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

// What the clean-up did: a cavity kept is a hole in the mesh, which a user should not miss.
void cleanup_section(UiContext& ctx) {
  const render::SceneData* scene = ctx.session.scene();
  if (!scene || !scene->volumes) return;
  const CleanupReport& c = scene->volumes->cleanup;
  ImGui::Text("specks dropped: %d (%zu voxels)", c.components_removed, c.voxels_removed);
  ImGui::Text("cavities filled: %d (%zu voxels)", c.cavities_filled, c.voxels_filled);
  if (c.cavities_kept > 0)
    ImGui::TextWrapped("cavities kept, too large to fill: %d (%zu voxels)", c.cavities_kept,
                       c.voxels_kept);
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

// Stage 6: stepping pass by pass, and the per-pass history.
void optimization_section(UiContext& ctx) {
  Session& s = ctx.session;
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
    return;
  }
  const int passes = int(r->history.size()) - 1;
  const bool finished = !scene->stale[int(Stage::optimize)];
  ImGui::Text("pass %d of at most %d%s, %.2f s; %zu inserted, %zu corners removed", passes,
              scene->parameters.optimization.max_passes, finished ? ", finished" : "", r->wall_s,
              r->inserted_vertices, r->corner_removals);
  ImGui::Text("boundary: within %.3g mm of the surface (before %.3g mm)",
              r->surface_distance_after_mm, r->surface_distance_before_mm);
  if (r->boundary_tolerance_mm > 0)
    ImGui::Text("%zu boundary vertices inserted where the segmentation lay beyond %.3g mm",
                r->inserted_boundary_vertices, r->boundary_tolerance_mm);
  std::vector<float> min_dihedral, bad;
  for (const PassStats& ps : r->history)
    if (ps.has_statistics) {
      min_dihedral.push_back(float(ps.min_dihedral_deg));
      bad.push_back(float(ps.below_10));
    }
  if (min_dihedral.empty()) return;
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
}

// The title of a stage's section: "3 CVT sampling".
std::string stage_title(Stage st) {
  std::string name(stage_name(st));
  name[0] = char(std::toupper(static_cast<unsigned char>(name[0])));
  return std::to_string(int(st) + 1) + " " + name;
}

bool is_object_selection(const ParameterSpec& spec) {
  return spec.section.empty() &&
         (spec.key == "labels" || spec.key == "iso" || spec.key == "inside_above");
}

// The parameters of one stage (Stage::count: those of no stage), then the stage's own controls.
bool stage_section(UiContext& ctx, Stage st) {
  Parameters& p = ctx.session.edited;
  const render::SceneData* scene = ctx.session.scene();
  bool changed = false;
  if (st == Stage::preprocess) changed |= edit_object_selection(ctx);
  for (const ParameterSpec& spec : parameter_registry()) {
    if (spec.stage != st || is_object_selection(spec)) continue;
    ImGui::BeginDisabled(!is_active(spec, p));  // e.g. stage 6's options with it off
    changed |= edit_parameter(spec, p);
    ImGui::EndDisabled();
    if (spec.key == "interior_spacing_mm" && scene && scene->default_interior_spacing_mm > 0 &&
        p.interior_spacing_mm == 0)
      ImGui::TextDisabled("auto spacing: %.3g mm", scene->default_interior_spacing_mm);
    // Once stage 2 has run with this budget (its r is resolved then; the interior points after
    // stage 3).
    if (spec.key == "target_vertices" && scene && p.target_vertices > 0 &&
        scene->sized_parameters.target_vertices == p.target_vertices && scene->surface_samples) {
      if (scene->sized_parameters.interior_points > 0)
        ImGui::TextDisabled("for it: r %.3g, %lld interior points", scene->sized_parameters.r,
                            static_cast<long long>(scene->sized_parameters.interior_points));
      else
        ImGui::TextDisabled("for it: r %.3g (interior points at stage 3)",
                            scene->sized_parameters.r);
    }
  }
  if (st == Stage::preprocess) cleanup_section(ctx);
  if (st == Stage::cvt) lloyd_section(ctx);
  if (st == Stage::optimize) optimization_section(ctx);
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
      ImGui::Text("%d %s", st + 1, std::string(stage_name(Stage(st))).c_str());
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

  bool changed = false;
  ImGui::PushItemWidth(120);
  for (int st = 0; st < kStageCount; ++st) {
    const bool has_parameters =
        std::any_of(parameter_registry().begin(), parameter_registry().end(),
                    [&](const ParameterSpec& spec) { return spec.stage == Stage(st); });
    if (has_parameters && stage_header(stage_title(Stage(st)).c_str(), states[st]))
      changed |= stage_section(ctx, Stage(st));
  }
  if (ImGui::CollapsingHeader("Other (threads, guards)")) changed |= stage_section(ctx, Stage::count);
  ImGui::PopItemWidth();
  if (changed) {
    clamp_to_ranges(s.edited);
    s.parameters_edited(ctx.ui.now_s);
  }
  ImGui::End();
}

}  // namespace cvt::gui
