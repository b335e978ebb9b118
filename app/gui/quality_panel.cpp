// The quality panel: counts, the paper's Table I (three measures × three bins), histograms,
// dihedral angles, validity and fidelity. Once stage 6 has started, Table I, the histogram and
// the dihedral figures show the stage-5 mesh (before) beside the current optimised one (after).
// Table I and the histograms come from the drawn mesh's per-tet measures, so they follow every
// optimisation pass; validity and fidelity come from the evaluation stage. Clicking a Table I
// cell or a histogram bar of the drawn mesh highlights those tets in the 3D view; clicking it
// again clears the highlight.
#include <imgui.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <vector>

#include "quality_selection.h"
#include "ui.h"

namespace cvt::gui {
namespace {

const char* measure_title(Measure m) {
  switch (m) {
    case Measure::VOverRmc3:
      return "V / r_mc^3";
    case Measure::GradientError:
      return "gradient error";
    case Measure::ConditionNumber:
      return "condition number";
    case Measure::MinDihedralDeg:
      return "min dihedral (deg)";
    case Measure::MaxDihedralDeg:
      return "max dihedral (deg)";
    case Measure::RadiusEdge:
      return "radius-edge ratio";
  }
  return "?";
}

void toggle_highlight(ViewSettings& view, const render::TetSelection& selection) {
  view.highlight = view.highlight == selection ? render::TetSelection{} : selection;
}

// Figures of the drawn mesh and of the stage-5 mesh, recomputed only when a new one arrives.
struct FiguresCache {
  std::uint64_t generation = 0;  // of the part the figures are of (0: always recomputed)
  render::MeshFigures figures;
  const render::MeshFigures& get(std::uint64_t part_generation,
                                 const std::array<std::vector<double>, 6>& measures) {
    if (part_generation != generation || part_generation == 0)
      generation = part_generation, figures = render::mesh_figures(measures);
    return figures;
  }
};

// A histogram's bar counts, recomputed only for a new part or another measure (a pass over
// millions of tets a frame took CPU from the pipeline while jobs ran).
struct HistogramCache {
  std::uint64_t generation = 0;  // of the part the counts are of (0: always recomputed)
  int measure = -1;
  std::vector<float> counts;
  const std::vector<float>& get(std::uint64_t part_generation, Measure m,
                                const std::vector<double>& values, int bars) {
    if (part_generation != generation || part_generation == 0 || measure != int(m)) {
      const auto c = render::measure_histogram(values, m, bars);
      generation = part_generation, measure = int(m), counts.assign(c.begin(), c.end());
    }
    return counts;
  }
};

// Table I of the drawn mesh (clickable); with `before`, a row of the stage-5 mesh above each.
void table_one(UiContext& ctx, const render::MeshFigures& after,
               const render::MeshFigures* before) {
  if (!ImGui::BeginTable("table1", 4, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingStretchProp))
    return;
  ImGui::TableSetupColumn("measure");
  ImGui::TableSetupColumn("low %");
  ImGui::TableSetupColumn("middle %");
  ImGui::TableSetupColumn("high %");
  ImGui::TableHeadersRow();
  for (int i = 0; i < 3; ++i) {
    const Measure m = kShewchukMeasures[i];
    const auto edges = table1_bin_edges(m);
    if (before) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextDisabled("%s, before", measure_title(m));
      for (int b = 0; b < 3; ++b) {
        ImGui::TableNextColumn();
        ImGui::TextDisabled("%.2f", before->bins_percent[i][b]);
      }
    }
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(before ? "  after" : measure_title(m));
    for (int b = 0; b < 3; ++b) {
      ImGui::TableNextColumn();
      render::TetSelection sel;
      sel.kind = render::TetSelection::Kind::table1_bin;
      sel.measure = m;
      sel.index = b;
      char text[48];
      std::snprintf(text, sizeof text, "%.2f##%d%d", after.bins_percent[i][b], i, b);
      if (ImGui::Selectable(text, ctx.view.highlight == sel)) toggle_highlight(ctx.view, sel);
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip("%s %s %.3g%s  (click: highlight these tets)", measure_title(m),
                          b == 0   ? "<"
                          : b == 1 ? "in ["
                                   : ">",
                          b == 2 ? edges[1] : edges[0],
                          b == 1 ? (", " + std::to_string(edges[1]) + "]").c_str() : "");
    }
  }
  ImGui::EndTable();
}

// A clickable histogram of one per-tet measure of the drawn mesh; with `before` (the stage-5
// mesh's values), its histogram first, on the same scale, not clickable (it is not drawn).
void histogram(UiContext& ctx, const render::MeshLayers& mesh, std::uint64_t generation,
               Measure m, const std::vector<double>* before, std::uint64_t before_generation) {
  const int bars = 20;
  static HistogramCache after_cache, before_cache;
  const std::vector<float>& values = after_cache.get(generation, m, mesh.measures[int(m)], bars);
  const render::MeasureScale scale = render::measure_scale(m);
  char overlay[96];
  const float width = ImGui::GetContentRegionAvail().x;
  float top = *std::max_element(values.begin(), values.end());
  if (before) {
    const std::vector<float>& bv = before_cache.get(before_generation, m, *before, bars);
    top = std::max(top, *std::max_element(bv.begin(), bv.end()));
    std::snprintf(overlay, sizeof overlay, "before: %s over [%.3g, %.3g]", measure_title(m),
                  scale.lo, scale.hi);
    ImGui::PushStyleColor(ImGuiCol_PlotHistogram, ImVec4(0.55f, 0.55f, 0.6f, 1.0f));
    ImGui::PlotHistogram("##histogram_before", bv.data(), bars, 0, overlay, 0.0f, top,
                         ImVec2(width, 70));
    ImGui::PopStyleColor();
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("the stage-5 mesh, before optimisation");
  }
  std::snprintf(overlay, sizeof overlay, "%s%s over [%.3g, %.3g]", before ? "after: " : "",
                measure_title(m), scale.lo, scale.hi);
  ImGui::PlotHistogram("##histogram", values.data(), bars, 0, overlay, 0.0f,
                       before ? top : FLT_MAX, ImVec2(width, before ? 70 : 90));
  const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
  const float pad = ImGui::GetStyle().FramePadding.x;
  const float x = ImGui::GetIO().MousePos.x;
  const int bar =
      std::clamp(int((x - lo.x - pad) / std::max(hi.x - lo.x - 2 * pad, 1.0f) * bars), 0, bars - 1);
  render::TetSelection sel;
  sel.kind = render::TetSelection::Kind::histogram_bar;
  sel.measure = m;
  sel.index = bar;
  sel.range = {scale.lo, scale.hi};
  sel.bars = bars;
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("%s: %zu tets (click: highlight)", render::describe(sel).c_str(),
                      std::size_t(values[std::size_t(bar)]));
  if (ImGui::IsItemClicked()) toggle_highlight(ctx.view, sel);
}

}  // namespace

void draw_quality_panel(UiContext& ctx) {
  if (!ctx.ui.show_quality) return;
  const Rect& r = ctx.ui.quality_panel;
  ImGui::SetNextWindowPos(ImVec2(r.x, r.y));
  ImGui::SetNextWindowSize(ImVec2(r.w, r.h));
  if (!ImGui::Begin(
          "Quality", &ctx.ui.show_quality,
          ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse)) {
    ImGui::End();
    return;
  }
  const render::SceneData* scene = ctx.session.scene();
  if (scene) {
    if (scene->surface_samples)
      ImGui::Text("surface samples B: %zu", scene->surface_samples->size());
    if (const auto lloyd = ctx.session.lloyd())
      ImGui::Text("interior sites: %zu", lloyd->sites_world.size());
    if (scene->shallow)
      ImGui::Text("interior I: %zu kept, %zu shallow removed", scene->shallow->kept_world.size(),
                  scene->shallow->removed_world.size());
    if (scene->mesh)
      ImGui::Text("mesh: %zu vertices, %zu tets, %zu exterior poles",
                  scene->mesh->mesh.vertices.size(), scene->mesh->mesh.tets.size(),
                  scene->mesh->exterior_poles.size());
  }
  if (!scene || !scene->mesh) {
    ImGui::TextDisabled("no mesh yet (run mesh generation)");
    ImGui::End();
    return;
  }
  static FiguresCache after_cache, before_cache;
  const render::MeshFigures& after =
      after_cache.get(scene->generations.mesh, scene->mesh->measures);
  const render::MeshFigures* before =
      scene->unoptimized
          ? &before_cache.get(scene->generations.unoptimized, scene->unoptimized->measures)
          : nullptr;
  ImGui::Separator();
  if (before) {
    const int passes = scene->optimization ? int(scene->optimization->history.size()) - 1 : 0;
    ImGui::Text("Table I %%: %zu tets before, %zu after %d pass%s", before->tets, after.tets,
                passes, passes == 1 ? "" : "es");
  } else {
    ImGui::Text("Table I (%% of %zu tets)", after.tets);
  }
  table_one(ctx, after, before);
  if (ctx.view.highlight.kind != render::TetSelection::Kind::none) {
    ImGui::Text("highlighted: %zu kept tets, %s", ctx.renderer.highlighted_tets,
                render::describe(ctx.view.highlight).c_str());
    ImGui::SameLine();
    if (ImGui::SmallButton("clear")) ctx.view.highlight = {};
  }
  static int measure = 0;
  const char* names[] = {"V / r_mc^3",   "gradient error", "condition number",
                         "min dihedral", "max dihedral",   "radius-edge"};
  ImGui::SetNextItemWidth(180);
  ImGui::Combo("histogram", &measure, names, 6);
  histogram(ctx, *scene->mesh, scene->generations.mesh, Measure(measure),
            before ? &scene->unoptimized->measures[measure] : nullptr,
            scene->generations.unoptimized);

  if (before) {
    ImGui::Text("dihedral angles: min %.2f -> %.2f deg, max %.2f -> %.2f deg",
                before->min_dihedral_deg, after.min_dihedral_deg, before->max_dihedral_deg,
                after.max_dihedral_deg);
    ImGui::Text("tets with min dihedral < 10 / 20 deg: %zu / %zu -> %zu / %zu", before->below_10,
                before->below_20, after.below_10, after.below_20);
  } else {
    ImGui::Text("dihedral angles: min %.2f deg, max %.2f deg", after.min_dihedral_deg,
                after.max_dihedral_deg);
    ImGui::Text("tets with min dihedral < 10 / 20 deg: %zu / %zu", after.below_10,
                after.below_20);
  }
  const QualityReport* q = scene->quality.get();
  if (!q) {
    ImGui::Separator();
    ImGui::TextDisabled("validity and fidelity: run the evaluation stage");
    ImGui::End();
    return;
  }
  const DihedralStats& d = q->dihedral;
  ImGui::Text("tets with max dihedral > 160/170 deg: %zu / %zu", d.above_160, d.above_170);
  ImGui::Separator();
  const Validity& v = q->validity;
  ImGui::TextColored(v.valid ? ImVec4(0.45f, 0.85f, 0.45f, 1) : ImVec4(1, 0.4f, 0.4f, 1), "%s",
                     v.valid ? "valid mesh" : "NOT a valid mesh");
  ImGui::Text("inverted %zu, zero volume %zu, unreferenced vertices %zu", v.inverted, v.zero_volume,
              v.unreferenced_vertices);
  ImGui::Text("boundary: %s, Euler characteristic %lld, %zu component(s)",
              v.boundary.closed_manifold ? "closed 2-manifold" : "not a closed manifold",
              v.boundary.euler_characteristic, v.boundary.components);
  if (const FidelityReport* f = scene->fidelity.get()) {
    ImGui::Separator();
    ImGui::Text("volume: mesh %.5g mm3, object %.5g mm3 (%+.2f %%)", f->mesh_volume_mm3,
                f->object_volume_mm3, f->volume_error_percent);
    ImGui::Text("Hausdorff %.3f mm, mean %.3f mm, p95 %.3f mm", f->distance.hausdorff_mm,
                f->distance.mean_mm, f->distance.p95_mm);
  }
  ImGui::End();
}

}  // namespace cvt::gui
