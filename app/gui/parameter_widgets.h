// The viewer's widget for any parameter of the registry, chosen by its type (checkbox, integer
// or number field, slider, choice), labelled with its unit and with a tooltip giving its
// meaning, range and the stage it re-runs. Call between ImGui::Begin and ImGui::End.
#pragma once

#include <string>

#include "pipeline/parameter_registry.h"

namespace cvt::gui {

// The widget's ImGui label: "margin (voxels)##margin_voxels".
std::string label_of(const ParameterSpec& spec);
// The tooltip of the last item, when hovered.
void tooltip(const ParameterSpec& spec);
// Draws the widget; true when the user changed the value. Labels and the iso value need the
// image (which labels exist, grey or not): the pipeline panel draws those itself.
bool edit_parameter(const ParameterSpec& spec, Parameters& p);

}  // namespace cvt::gui
