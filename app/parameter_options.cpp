#include "parameter_options.h"

#include <map>
#include <string>
#include <type_traits>

#include "base/errors.h"
#include "pipeline/parameter_registry.h"
#include "pipeline/preset.h"
#include "preprocess/object_selection.h"

namespace cvt::cli {
namespace {

std::string group_of(const ParameterSpec& spec) {
  if (spec.stage == Stage::count) return "How the run is carried out (no effect on the mesh)";
  return "Stage " + std::to_string(int(spec.stage) + 1) + ": " + std::string(stage_name(spec.stage));
}

std::string help_of(const ParameterSpec& spec) {
  std::string help(spec.tooltip);
  if (const std::string range = range_text(spec); !range.empty()) help += " [" + range + "]";
  return help;
}

}  // namespace

ParameterOptions::ParameterOptions(CLI::App* cmd, Scope scope) {
  cmd->add_option("--preset", preset_path_, "Parameter preset (JSON) to start from");
  std::map<std::string_view, CLI::Option*> by_cli;
  for (const ParameterSpec& spec : parameter_registry()) {
    if (scope == Scope::object && !spec.defines_object) continue;
    const std::string name = "--" + std::string(spec.cli);
    const std::string help = help_of(spec);
    CLI::Option* opt = nullptr;
    std::function<void(Parameters&)> apply;
    visit_parameter(spec, given_, [&](auto& member) {
      using T = std::decay_t<decltype(member)>;
      const auto words = CLI::IsMember({std::string(spec.words[0]), std::string(spec.words[1])});
      if constexpr (std::is_same_v<T, std::vector<std::int64_t>>) {
        std::string& text = texts_.emplace_back("all");
        opt = cmd->add_option(name, text, help);
        apply = [&spec, &text](Parameters& p) {
          visit_parameter(spec, p, [&](auto& out) {
            if constexpr (std::is_same_v<std::decay_t<decltype(out)>, T>)
              out = parse_label_list(text);
          });
        };
      } else if constexpr (std::is_same_v<T, std::optional<double>>) {
        double& value = numbers_.emplace_back(0.0);
        opt = cmd->add_option(name, value, help);
        apply = [&spec, &value](Parameters& p) {
          visit_parameter(spec, p, [&](auto& out) {
            if constexpr (std::is_same_v<std::decay_t<decltype(out)>, T>) out = value;
          });
        };
      } else if constexpr (is_word_switch_v<T> || std::is_same_v<T, bool>) {
        if (std::is_same_v<T, bool> && spec.words[0].empty()) {  // true / false
          opt = cmd->add_option(name, member, help);
        } else {
          std::string& text = texts_.emplace_back();
          opt = cmd->add_option(name, text, help)->check(words);
          apply = [&spec, &text](Parameters& p) {
            visit_parameter(spec, p, [&](auto& out) {
              if constexpr (std::is_same_v<std::decay_t<decltype(out)>, T>)
                out = T(text == spec.words[1]);
            });
          };
        }
      } else {
        opt = cmd->add_option(name, member, help);
      }
    });
    if (!apply) apply = [this, &spec](Parameters& p) { copy_value(spec, given_, p); };
    opt->group(group_of(spec));
    by_cli[spec.cli] = opt;
    bindings_.push_back({opt, std::move(apply)});
  }
  for (const ParameterSpec& spec : parameter_registry())
    if (!spec.excludes.empty() && by_cli.count(spec.cli) && by_cli.count(spec.excludes))
      by_cli[spec.cli]->excludes(by_cli[spec.excludes]);
}

Parameters ParameterOptions::resolve() const {
  Parameters p = preset_path_.empty() ? Parameters{} : load_preset(preset_path_);
  for (const auto& [opt, apply] : bindings_)
    if (opt->count() > 0) apply(p);
  try {
    validate(p);
  } catch (const InputError& e) {
    throw InputError(std::string("parameter ") + e.what());
  }
  return p;
}

}  // namespace cvt::cli
