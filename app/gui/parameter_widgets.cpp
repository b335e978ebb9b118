#include "parameter_widgets.h"

#include <imgui.h>

#include <type_traits>

namespace cvt::gui {

void tooltip(const ParameterSpec& spec) {
  if (!ImGui::IsItemHovered()) return;
  const std::string range = range_text(spec);
  const std::string stage = stales_from(spec) == Stage::count
                                ? "changes no result"
                                : "re-runs from stage " + std::to_string(int(spec.stage) + 1) +
                                      ", " + std::string(stage_name(spec.stage));
  ImGui::SetTooltip("%.*s%s%s\n(%s; preset key %s)", int(spec.tooltip.size()), spec.tooltip.data(),
                    range.empty() ? "" : "\n", range.c_str(), stage.c_str(), spec.name().c_str());
}

std::string label_of(const ParameterSpec& spec) {
  return spec.label_with_unit() + "##" + spec.name();
}

bool edit_parameter(const ParameterSpec& spec, Parameters& p) {
  const std::string label = label_of(spec);
  bool changed = false;
  visit_parameter(spec, p, [&](auto& v) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (std::is_same_v<T, bool>) {
      changed = ImGui::Checkbox(label.c_str(), &v);
    } else if constexpr (std::is_same_v<T, int>) {
      changed = ImGui::InputInt(label.c_str(), &v);
    } else if constexpr (std::is_same_v<T, std::int64_t>) {
      changed = ImGui::InputScalar(label.c_str(), ImGuiDataType_S64, &v);
    } else if constexpr (std::is_same_v<T, std::uint64_t>) {
      changed = ImGui::InputScalar(label.c_str(), ImGuiDataType_U64, &v);
    } else if constexpr (std::is_same_v<T, double>) {
      if (spec.slider[1] > spec.slider[0])
        changed = ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &v, &spec.slider[0],
                                      &spec.slider[1], "%.3f");
      else
        changed = ImGui::InputDouble(label.c_str(), &v, 0.0, 0.0, "%.4g");
    } else if constexpr (is_word_switch_v<T>) {
      int index = int(v);
      const std::string items = std::string(spec.words[0]) + '\0' + std::string(spec.words[1]) + '\0';
      if (ImGui::Combo(label.c_str(), &index, items.c_str())) v = T(index), changed = true;
    }
  });
  tooltip(spec);
  return changed;
}

}  // namespace cvt::gui
