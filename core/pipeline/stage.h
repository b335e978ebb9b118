// The pipeline's stages: the paper's five (section III) and ours, in run order. Each has its
// own result in the Pipeline; a parameter names the first stage whose result it changes.
#pragma once

#include <optional>
#include <string_view>

namespace cvt {

enum class Stage {
  preprocess,  // 1: object, clean-up, smoothed indicator, medial axis, lfs
  surface,     // 2: greedy r-sampling of the boundary (Algorithm 1)
  cvt,         // 3: CVT interior samples by Lloyd iterations (Algorithm 2)
  shallow,     // 4: shallow-point removal
  mesh,        // 5: Delaunay mesh with exterior poles, fidelity refinement
  optimize,    // 6: optimisation (ours)
  evaluate,    // 7: quality and validity; fidelity when asked (ours)
  count        // not a stage: "no stage" where a Stage is expected
};
inline constexpr int kStageCount = int(Stage::count);

// Short key ("preprocess", "surface", ... "evaluate"), as command lines take it.
std::string_view stage_key(Stage stage);
// Name for people ("surface sampling"); also the name of the stage's run record.
std::string_view stage_name(Stage stage);
std::optional<Stage> stage_from_key(std::string_view key);

// Run records of a part of a stage: evaluation times its two parts apart, and stage 6 stepped
// pass by pass records each step.
inline constexpr std::string_view kQualityRecord = "quality";
inline constexpr std::string_view kFidelityRecord = "fidelity";
inline constexpr std::string_view kOptimizationPassesRecord = "optimisation passes";
// The stage a run record (a stage_name or a part's name) belongs to; Stage::count for none.
Stage stage_of_record(std::string_view name);

}  // namespace cvt
