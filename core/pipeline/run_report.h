// The run report (`cvtmesh mesh --report`): parameters, per-stage time and memory, Lloyd
// history, counts, quality and fidelity, as JSON (layout in ../shared/DESIGN.md).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include "pipeline/pipeline.h"

namespace cvt {

nlohmann::json run_report(const Pipeline& pipeline);
// The image's file and geometry (dims, spacing, origin, direction, LPS) and, for NIfTI, the
// frame used and both header transforms ({code, matrix}: index → RAS mm, 4×4, null when the
// code is 0) with the warnings of reading it. `cvtmesh info --json` and the run report's "image".
nlohmann::json image_json(const Image& image);

}  // namespace cvt
