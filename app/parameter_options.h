// Binds every parameter of the registry to a CLI option (--KEY as the registry names it);
// options given on the command line override a preset, which overrides the defaults.
#pragma once

#include <deque>
#include <functional>
#include <string>
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
  explicit ParameterOptions(CLI::App* cmd, Scope scope = Scope::all);
  ParameterOptions(const ParameterOptions&) = delete;  // the options point into this object
  ParameterOptions& operator=(const ParameterOptions&) = delete;
  // Defaults ← preset file (if --preset) ← options given. Throws InputError on bad values.
  Parameters resolve() const;

 private:
  Parameters given_;                // typed values CLI11 parsed into
  std::deque<std::string> texts_;   // values parsed by the registry's words or label lists
  std::deque<double> numbers_;      // optional numbers (iso)
  std::string preset_path_;
  std::vector<std::pair<CLI::Option*, std::function<void(Parameters&)>>> bindings_;
};

}  // namespace cvt::cli
