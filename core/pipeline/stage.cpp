#include "pipeline/stage.h"

#include <array>

namespace cvt {
namespace {

struct StageNames {
  std::string_view key, name;
};
constexpr std::array<StageNames, kStageCount> kStages{{{"preprocess", "preprocess"},
                                                        {"surface", "surface sampling"},
                                                        {"cvt", "CVT sampling"},
                                                        {"shallow", "shallow points"},
                                                        {"mesh", "mesh generation"},
                                                        {"optimize", "optimisation"},
                                                        {"evaluate", "evaluation"}}};

}  // namespace

std::string_view stage_key(Stage stage) {
  return stage == Stage::count ? "none" : kStages[int(stage)].key;
}

std::string_view stage_name(Stage stage) {
  return stage == Stage::count ? "none" : kStages[int(stage)].name;
}

std::optional<Stage> stage_from_key(std::string_view key) {
  for (int s = 0; s < kStageCount; ++s)
    if (kStages[s].key == key) return Stage(s);
  return std::nullopt;
}

Stage stage_of_record(std::string_view name) {
  for (int s = 0; s < kStageCount; ++s)
    if (kStages[s].name == name) return Stage(s);
  if (name == kQualityRecord || name == kFidelityRecord) return Stage::evaluate;
  if (name == kOptimizationPassesRecord) return Stage::optimize;
  return Stage::count;
}

}  // namespace cvt
