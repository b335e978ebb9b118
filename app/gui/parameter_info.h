// Meaning, unit and stage of every pipeline parameter (the comments of core/parameters.h), for
// the pipeline panel's labels and tooltips. Keys are the preset (JSON) keys. GL-free.
#pragma once

#include <string_view>
#include <vector>

#include "pipeline/pipeline.h"

namespace cvt::gui {

struct ParameterInfo {
  std::string_view key;      // preset key, e.g. "sigma_surface_mm"
  std::string_view label;    // short label in the panel
  std::string_view tooltip;  // meaning and unit
  Stage stage;               // the first stage it changes
};

// In panel order (stage by stage); one entry per field of Parameters.
const std::vector<ParameterInfo>& parameter_infos();
// Null for an unknown key.
const ParameterInfo* find_parameter_info(std::string_view key);

}  // namespace cvt::gui
