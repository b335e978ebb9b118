// Presets: Parameters as JSON, in and out. Unknown keys, wrong types and out-of-range values
// are refused with one line naming the key (and the file).
#pragma once

#include <string>

#include <nlohmann/json_fwd.hpp>

#include "pipeline/parameters.h"

namespace cvt {

nlohmann::json to_json(const Parameters& parameters);
// Keys missing from `json` keep their values in `base`.
Parameters parameters_from_json(const nlohmann::json& json, const Parameters& base = {});

Parameters load_preset(const std::string& path, const Parameters& base = {});
// Written to a temp file and renamed, so a failure never leaves half a preset.
void save_preset(const Parameters& parameters, const std::string& path);

// Writes `text` to `path` atomically (temp file beside it, then rename); throws InputError
// naming the path on failure.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace cvt
