// The parameter registry: every parameter declared once, with its key, type (the member's),
// default (the member's initialiser), unit, range, stage, label and tooltip. Presets, the CLI
// options, the viewer's panel, validation and stale-stage tracking are all derived from it.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "pipeline/parameters.h"
#include "pipeline/stage.h"

namespace cvt {

// The member a row describes; its type is the parameter's type.
using ParameterRef = std::variant<bool*, int*, std::int64_t*, std::uint64_t*, double*,
                                  std::optional<double>*, std::vector<std::int64_t>*,
                                  OptimizeMode*, NiftiFrame*>;

// The switches named by two words (ParameterSpec::words, in enum order).
template <class T>
inline constexpr bool is_word_switch_v =
    std::is_same_v<T, OptimizeMode> || std::is_same_v<T, NiftiFrame>;

struct ParameterSpec {
  std::string_view key;      // preset key (within `section`'s object when there is one)
  std::string_view section;  // "" or "optimization" (preset {"optimization": {...}})
  std::string_view cli;      // command-line option, without "--"
  std::string_view label;    // the viewer's label, without the unit
  std::string_view unit;     // "mm", "voxels", "°", "MB", or "" (counts, ratios, switches)
  // The stage it belongs to; Stage::count: none (threads, the guards).
  Stage stage = Stage::count;
  bool changes_no_result = false;  // so changing it re-runs nothing (σ surface)
  std::string_view tooltip;  // meaning (and what 0 means, where it is special)
  // Range of a number (integers, reals, iso), open or closed at each end.
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
  std::string_view zero_means;  // "auto", "all cores" ...: 0 is not a plain value
  // OptimizeMode, NiftiFrame: the names of its values (in enum order) in presets, the CLI and
  // the viewer.
  // bool: the CLI's words for false and true, when not "false" and "true" (--inside below).
  std::array<std::string_view, 2> words{};
  bool defines_object = false;    // selection and clean-up of the object (`quality --image`)
  std::array<double, 2> slider{};  // the viewer shows a slider over this range (if hi > lo)
  std::string_view excludes;       // a CLI option it cannot be given with
  ParameterRef (*ref)(Parameters&) = nullptr;
  // Null, or false where the parameter has no effect (stage 6's options with optimize = none):
  // a change then re-runs nothing and the viewer greys it out.
  bool (*active)(const Parameters&) = nullptr;

  // "optimization.max_passes" or "r": the name errors use.
  std::string name() const;
  // "margin (voxels)".
  std::string label_with_unit() const;
};

// Every parameter, stage by stage in run order (the panel's order).
const std::vector<ParameterSpec>& parameter_registry();
// Null for an unknown key (the section's own keys are "optimization.KEY" or KEY in `section`).
const ParameterSpec* find_parameter(std::string_view section, std::string_view key);

// Calls fn with the member of `p` the row names (a reference of the parameter's type; const
// when p is), so callers need not tell the types apart.
template <class F>
void visit_parameter(const ParameterSpec& spec, Parameters& p, F&& fn) {
  std::visit([&](auto* member) { fn(*member); }, spec.ref(p));
}
template <class F>
void visit_parameter(const ParameterSpec& spec, const Parameters& p, F&& fn) {
  std::visit([&](auto* member) { fn(std::as_const(*member)); },
             spec.ref(const_cast<Parameters&>(p)));
}
bool same_value(const ParameterSpec& spec, const Parameters& a, const Parameters& b);
void copy_value(const ParameterSpec& spec, const Parameters& from, Parameters& to);

// Throws InputError "KEY: must be ..." for the first value out of its range.
void validate(const Parameters& parameters);
// Brings every number into its range where that end is closed (the viewer's fields); open
// ends are left to validate().
void clamp_to_ranges(Parameters& parameters);
// The range's text, e.g. "must be in (0, 1)" or "must be >= 0 (0 = auto)".
std::string range_text(const ParameterSpec& spec);

// The first stage whose result a change of the parameter makes stale (Stage::count: none).
inline Stage stales_from(const ParameterSpec& spec) {
  return spec.changes_no_result ? Stage::count : spec.stage;
}
inline bool is_active(const ParameterSpec& spec, const Parameters& p) {
  return !spec.active || spec.active(p);
}
// The word a preset and the CLI use for a value of the optimize switch ("none", "default").
std::string_view optimize_word(OptimizeMode mode);
// The first stage whose result depends on a parameter that differs (Stage::count if none).
Stage first_changed_stage(const Parameters& a, const Parameters& b);

}  // namespace cvt
