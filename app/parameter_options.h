// Binds every pipeline parameter to a CLI option; options given on the command line override
// a preset, which overrides the defaults.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include <CLI/CLI.hpp>

#include "pipeline/parameters.h"

namespace cvt::cli {

class ParameterOptions {
 public:
  enum class Scope {
    all,     // every parameter (`mesh`)
    object,  // --preset and the object's selection and clean-up only (`quality --image`)
  };
  // Registers --labels, --iso, --inside, --r, ... on `cmd`.
  explicit ParameterOptions(CLI::App* cmd, Scope scope = Scope::all);
  // Defaults ← preset file (if --preset) ← options given. Throws InputError on bad values.
  Parameters resolve() const;

 private:
  Parameters given_;               // values CLI11 parsed into
  std::string labels_text_ = "all", inside_text_ = "above", preset_path_;
  double iso_ = 0;
  std::vector<std::pair<CLI::Option*, std::function<void(Parameters&)>>> bindings_;
};

}  // namespace cvt::cli
