// Stage 6's options in the viewer: every field of OptimizationOptions with its label, tooltip
// (meaning and unit) and range, for the pipeline panel, and their comparison (the panel marks
// edits pending, a job applies them only when they changed, since applying restarts stage 6).
// The viewer collects per-pass statistics, for its before/after history. GL-free.
#pragma once

#include <string_view>
#include <vector>

#include "mesh_optimization.h"

namespace cvt::gui {

struct OptimizationField {
  std::string_view key;      // the OptimizationOptions member's name
  std::string_view label;    // short label in the panel
  std::string_view tooltip;  // meaning and unit
  // Exactly one of these points at the member.
  double OptimizationOptions::*real = nullptr;
  int OptimizationOptions::*integer = nullptr;
  bool OptimizationOptions::*flag = nullptr;
  double lo = 0, hi = 0;  // range the panel keeps numbers in
};

// In panel order; every member of OptimizationOptions but pass_statistics.
const std::vector<OptimizationField>& optimization_fields();
// The viewer's defaults: the CLI's, plus statistics after every pass.
OptimizationOptions viewer_optimization_options();
// Every member equal.
bool same_optimization_options(const OptimizationOptions& a, const OptimizationOptions& b);
// Keeps the numbers of the panel's fields in their ranges.
void clamp_optimization_options(OptimizationOptions& o);

}  // namespace cvt::gui
