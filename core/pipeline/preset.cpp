#include "pipeline/preset.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <utility>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "base/errors.h"
#include "pipeline/parameter_registry.h"

namespace cvt {
namespace {

using nlohmann::json;

const char* type_name(const json& j) { return j.type_name(); }

template <class T>
void read_value(const json& j, const ParameterSpec& spec, T& out) {
  const std::string key = spec.name();
  if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) throw InputError(key + ": expected true or false, got " + type_name(j));
    out = j.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!j.is_number_integer()) throw InputError(key + ": expected an integer, got " + j.dump());
    if constexpr (std::is_unsigned_v<T>)
      if (j.is_number_integer() && !j.is_number_unsigned() && j.get<std::int64_t>() < 0)
        throw InputError(key + ": must not be negative");
    // get<T> would wrap a value beyond T (4294967297 threads would become 1).
    const bool fits = j.is_number_unsigned()
                          ? j.get<std::uint64_t>() <= std::uint64_t(std::numeric_limits<T>::max())
                          : std::in_range<T>(j.get<std::int64_t>());
    if (!fits) throw InputError(key + ": " + j.dump() + " is out of range");
    out = j.get<T>();
  } else if constexpr (std::is_floating_point_v<T>) {
    if (!j.is_number()) throw InputError(key + ": expected a number, got " + type_name(j));
    out = j.get<T>();
  } else if constexpr (std::is_same_v<T, std::optional<double>>) {
    if (j.is_null()) {
      out.reset();
    } else {
      double v;
      read_value(j, spec, v);
      out = v;
    }
  } else if constexpr (is_word_switch_v<T>) {
    const auto& words = spec.words;
    if (!j.is_string() || (j.get<std::string>() != words[0] && j.get<std::string>() != words[1]))
      throw InputError(key + ": must be \"" + std::string(words[0]) + "\" or \"" +
                       std::string(words[1]) + "\"");
    out = T(j.get<std::string>() == words[1]);
  } else {  // label list: "all" or an array of integers
    if (j.is_string() && j.get<std::string>() == "all") {
      out.clear();
      return;
    }
    if (!j.is_array()) throw InputError(key + ": expected \"all\" or a list of integer labels");
    out.clear();
    for (const json& item : j) {
      std::int64_t v;
      read_value(item, spec, v);
      out.push_back(v);
    }
  }
}

}  // namespace

json to_json(const Parameters& p) {
  json j = json::object();
  for (const ParameterSpec& spec : parameter_registry()) {
    json& slot = spec.section.empty() ? j[std::string(spec.key)]
                                      : j[std::string(spec.section)][std::string(spec.key)];
    visit_parameter(spec, p, [&](const auto& value) {
      using T = std::decay_t<decltype(value)>;
      if constexpr (std::is_same_v<T, std::optional<double>>)
        slot = value ? json(*value) : json(nullptr);
      else if constexpr (std::is_same_v<T, std::vector<std::int64_t>>)
        slot = value.empty() ? json("all") : json(value);
      else if constexpr (is_word_switch_v<T>)
        slot = std::string(spec.words[int(value)]);
      else
        slot = value;
    });
  }
  return j;
}

Parameters parameters_from_json(const json& j, const Parameters& base) {
  if (!j.is_object()) throw InputError("preset: expected a JSON object of parameters");
  Parameters p = base;
  auto read = [&](std::string_view section, const std::string& key, const json& value) {
    const ParameterSpec* spec = find_parameter(section, key);
    if (!spec)
      throw InputError("unknown parameter '" +
                       (section.empty() ? key : std::string(section) + "." + key) + "'");
    visit_parameter(*spec, p, [&](auto& member) { read_value(value, *spec, member); });
  };
  const auto& registry = parameter_registry();
  for (auto it = j.begin(); it != j.end(); ++it) {
    const bool section = std::any_of(registry.begin(), registry.end(), [&](const ParameterSpec& s) {
      return !s.section.empty() && s.section == it.key();
    });
    if (!section) {
      read("", it.key(), *it);
      continue;
    }
    if (!it->is_object()) throw InputError(it.key() + ": expected an object of options");
    for (auto o = it->begin(); o != it->end(); ++o) read(it.key(), o.key(), *o);
  }
  validate(p);
  return p;
}

Parameters load_preset(const std::string& path, const Parameters& base) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open preset");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(path + ": not valid JSON (byte " + std::to_string(e.byte) + ")");
  } catch (const json::out_of_range&) {  // a number beyond double, such as 1e999
    throw InputError(path + ": not valid JSON (a number is out of range)");
  }
  try {
    return parameters_from_json(j, base);
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
}

void write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  if (!fs::is_directory(dir)) throw InputError("cannot write " + path + ": folder does not exist");
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(getpid()));
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw InputError("cannot write " + path + ": permission denied or invalid path");
    out << text;
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw InputError("cannot write " + path + ": write failed (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError("cannot write " + path + ": " + ec.message());
  }
}

void save_preset(const Parameters& parameters, const std::string& path) {
  validate(parameters);
  write_file_atomically(path, to_json(parameters).dump(2) + "\n");
}

}  // namespace cvt
