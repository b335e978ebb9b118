// The parameter registry walked row by row: every parameter survives a preset round trip, is
// given by its CLI option, gets a viewer widget with a label and tooltip, and makes exactly the
// stages from its own one stale in a real Pipeline.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "parameter_options.h"
#include "phantoms.h"
#include "pipeline/parameter_registry.h"
#include "pipeline/pipeline.h"
#include "pipeline/preset.h"

#ifdef CVTMESH_HAS_GUI_WIDGETS
#include <imgui.h>
#include <imgui_internal.h>

#include "parameter_widgets.h"
#endif

using namespace cvt;

namespace {

// A valid value other than the default, and how the CLI spells it.
struct Changed {
  Parameters p;
  std::string cli_text;
};

template <class T>
std::string text_of(const T& v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

Changed changed_value(const ParameterSpec& spec) {
  Changed c;
  visit_parameter(spec, c.p, [&](auto& v) {
    using T = std::decay_t<decltype(v)>;
    // A number inside the range, away from the default.
    auto inside = [&](double def) {
      const double lo = std::isfinite(spec.lo) ? spec.lo : 0.0;
      const double hi = std::isfinite(spec.hi) ? spec.hi : lo + 100.0;
      double x = def + 0.25 * (hi - lo);
      if (x >= hi || (spec.hi_open && x >= hi)) x = def - 0.25 * (hi - lo);
      if (x < lo || (spec.lo_open && x <= lo)) x = 0.5 * (lo + hi);
      return x;
    };
    if constexpr (std::is_same_v<T, bool>) {
      v = !v;
      c.cli_text = spec.words[0].empty() ? (v ? "true" : "false") : std::string(spec.words[v]);
    } else if constexpr (cvt::is_word_switch_v<T>) {
      v = T(1 - int(v));
      c.cli_text = std::string(spec.words[int(v)]);
    } else if constexpr (std::is_integral_v<T>) {
      v = T(std::llround(inside(double(v)))) == v ? T(v + 1) : T(std::llround(inside(double(v))));
      c.cli_text = text_of(v);
    } else if constexpr (std::is_same_v<T, double>) {
      v = inside(v);
      c.cli_text = text_of(v);
    } else if constexpr (std::is_same_v<T, std::optional<double>>) {
      v = 2.5;
      c.cli_text = "2.5";
    } else if constexpr (std::is_same_v<T, std::vector<std::int64_t>>) {
      v = {3, 7};
      c.cli_text = "3,7";
    }
  });
  return c;
}

std::shared_ptr<const Image> small_sphere() {
  const Phantom s = sphere_phantom({1, -2, 3}, 4.0);
  return std::make_shared<Image>(rasterize(s, grid_around(s, {0.8, 0.9, 1.1}, rotation_matrix({0, 0, 1}, 0.2))));
}

}  // namespace

TEST(ParameterRegistry, EveryRowIsComplete) {
  std::set<std::string> names, options;
  for (const ParameterSpec& spec : parameter_registry()) {
    SCOPED_TRACE(spec.name());
    EXPECT_TRUE(names.insert(spec.name()).second) << "key declared twice";
    EXPECT_TRUE(options.insert(std::string(spec.cli)).second) << "CLI option declared twice";
    EXPECT_FALSE(spec.label.empty());
    EXPECT_FALSE(spec.tooltip.empty());
    ASSERT_NE(spec.ref, nullptr);
    // Units follow the key's suffix (lengths in mm, angles in degrees, voxel multiples).
    const std::string key(spec.key);
    auto ends = [&](std::string_view s) {
      return key.size() > s.size() && key.compare(key.size() - s.size(), s.size(), s) == 0;
    };
    if (ends("_mm")) EXPECT_EQ(spec.unit, "mm");
    if (ends("_deg")) EXPECT_EQ(spec.unit, "°");
    if (ends("_voxels")) EXPECT_EQ(spec.unit, "voxels");
    if (!spec.unit.empty()) EXPECT_NE(spec.label_with_unit().find(spec.unit), std::string::npos);
    // Stage 6's counts say so (the others are caps and counts by their labels).
    visit_parameter(spec, Parameters{}, [&](const auto& v) {
      if (std::is_same_v<std::decay_t<decltype(v)>, int> && spec.section == "optimization")
        EXPECT_NE(spec.tooltip.find("count"), std::string_view::npos);
    });
    // The default is valid, and a changed value differs from it.
    const Changed c = changed_value(spec);
    EXPECT_FALSE(same_value(spec, c.p, Parameters{}));
    EXPECT_NO_THROW(validate(c.p));
  }
  EXPECT_NO_THROW(validate(Parameters{}));
}

TEST(ParameterRegistry, EveryParameterRoundTripsThroughAPreset) {
  for (const ParameterSpec& spec : parameter_registry()) {
    SCOPED_TRACE(spec.name());
    const Changed c = changed_value(spec);
    const nlohmann::json j = to_json(c.p);
    const nlohmann::json& slot = spec.section.empty() ? j : j.at(std::string(spec.section));
    EXPECT_TRUE(slot.contains(std::string(spec.key)));
    EXPECT_EQ(parameters_from_json(j), c.p);
    // Only this key given: the rest keeps the base.
    nlohmann::json only = nlohmann::json::object();
    if (spec.section.empty())
      only[std::string(spec.key)] = slot.at(std::string(spec.key));
    else
      only[std::string(spec.section)][std::string(spec.key)] = slot.at(std::string(spec.key));
    EXPECT_EQ(parameters_from_json(only), c.p);
  }
}

TEST(ParameterRegistry, EveryParameterHasItsCliOption) {
  for (const ParameterSpec& spec : parameter_registry()) {
    SCOPED_TRACE(spec.name());
    const Changed c = changed_value(spec);
    CLI::App app;
    cli::ParameterOptions options(&app);
    const std::string flag = "--" + std::string(spec.cli);
    std::vector<std::string> args{c.cli_text, flag};  // CLI11 takes them last to first
    ASSERT_NO_THROW(app.parse(args));
    EXPECT_EQ(options.resolve(), c.p);
    // The object scope (`quality --image`) has exactly the object's parameters.
    CLI::App object_app;
    cli::ParameterOptions object(&object_app, cli::ParameterOptions::Scope::object);
    EXPECT_EQ(object_app.get_option_no_throw(flag) != nullptr, spec.defines_object);
  }
}

#ifdef CVTMESH_HAS_GUI_WIDGETS
TEST(ParameterRegistry, EveryParameterHasAViewerWidget) {
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.DisplaySize = ImVec2(800, 2000);
  io.IniFilename = nullptr;
  unsigned char* pixels;
  int w, h;
  io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);  // a font atlas, no GPU needed
  ImGui::NewFrame();
  ImGui::SetNextWindowSize(ImVec2(700, 1900));
  ImGui::Begin("registry");
  Parameters p;
  for (const ParameterSpec& spec : parameter_registry()) {
    SCOPED_TRACE(spec.name());
    if (spec.key == "labels" || spec.key == "iso") continue;  // the panel's object selection
    const float y = ImGui::GetCursorPosY();
    gui::edit_parameter(spec, p);
    // One widget row was drawn, wide enough for its label and unit (an integer field is a
    // group of the field, its step buttons and the label, so no single item ID).
    EXPECT_GT(ImGui::GetCursorPosY(), y);
    EXPECT_GE(ImGui::GetItemRectSize().x, ImGui::CalcTextSize(spec.label_with_unit().c_str()).x);
    EXPECT_EQ(gui::label_of(spec).rfind(spec.label_with_unit(), 0), 0u);
  }
  ImGui::End();
  ImGui::EndFrame();
  ImGui::DestroyContext();
  EXPECT_EQ(p, Parameters{});  // drawing changes nothing
}
#endif

TEST(ParameterRegistry, EveryParameterMakesItsStageAndDownstreamStale) {
  Pipeline pipe;
  pipe.set_image(small_sphere());
  Parameters base;
  base.max_iterations = 3;
  base.optimization.max_passes = 2;
  pipe.set_parameters(base);
  pipe.run_all();
  for (const ParameterSpec& spec : parameter_registry()) {
    SCOPED_TRACE(spec.name());
    Parameters p = base;
    copy_value(spec, changed_value(spec).p, p);
    if (same_value(spec, p, base)) continue;  // base's own value (max_iterations): no change
    const Stage from = stales_from(spec);
    EXPECT_EQ(first_changed_stage(base, p), from);
    pipe.set_parameters(p);
    for (int s = 0; s < kStageCount; ++s)
      EXPECT_EQ(pipe.is_stale(Stage(s)), s >= int(from)) << stage_name(Stage(s));
    pipe.set_parameters(base);
    pipe.run_all();
  }
  // With stage 6 off, its options have no effect: changing one re-runs nothing.
  Parameters off = base;
  off.optimize = OptimizeMode::none;
  pipe.set_parameters(off);
  pipe.run_all();
  ASSERT_EQ(pipe.optimized(), nullptr);
  ASSERT_EQ(pipe.final_mesh(), &pipe.mesh()->mesh);
  for (const ParameterSpec& spec : parameter_registry()) {
    if (spec.section != "optimization") continue;
    SCOPED_TRACE(spec.name());
    Parameters p = off;
    copy_value(spec, changed_value(spec).p, p);
    EXPECT_FALSE(is_active(spec, p));
    EXPECT_EQ(first_changed_stage(off, p), Stage::count);
    pipe.set_parameters(p);
    for (int s = 0; s < kStageCount; ++s) EXPECT_FALSE(pipe.is_stale(Stage(s)));
  }
}
