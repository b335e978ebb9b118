// The run report (`cvtmesh mesh --report`): parameters, per-stage time and memory, Lloyd
// history, counts, quality and fidelity, as JSON (layout in ../shared/DESIGN.md).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include "pipeline/pipeline.h"

namespace cvt {

nlohmann::json run_report(const Pipeline& pipeline);

}  // namespace cvt
