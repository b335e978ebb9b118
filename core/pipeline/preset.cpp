#include "pipeline/preset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "base/errors.h"

namespace cvt {
namespace {

using nlohmann::json;

// One table drives both directions, so a new parameter is one line here.
template <class F>
void for_each_field(Parameters& p, F&& f) {
  f("labels", p.labels);
  f("iso", p.iso);
  f("inside_above", p.inside_above);
  f("margin_voxels", p.margin_voxels);
  f("remove_small_components", p.remove_small_components);
  f("min_component_fraction", p.min_component_fraction);
  f("fill_cavities", p.fill_cavities);
  f("smoothing_sigma_mm", p.smoothing_sigma_mm);
  f("medial_min_separation_mm", p.medial_min_separation_mm);
  f("medial_min_angle_deg", p.medial_min_angle_deg);
  f("lfs_min_mm", p.lfs_min_mm);
  f("lfs_max_mm", p.lfs_max_mm);
  f("r", p.r);
  f("sigma_surface_mm", p.sigma_surface_mm);
  f("project_samples", p.project_samples);
  f("sigma_density_mm", p.sigma_density_mm);
  f("interior_spacing_mm", p.interior_spacing_mm);
  f("interior_points", p.interior_points);
  f("epsilon_mm", p.epsilon_mm);
  f("max_iterations", p.max_iterations);
  f("fidelity_rounds", p.fidelity_rounds);
  f("fidelity_tolerance_mm", p.fidelity_tolerance_mm);
  f("optimize", p.optimize);
  f("optimization", p.optimization);
  f("seed", p.seed);
  f("threads", p.threads);
  f("max_points", p.max_points);
  f("max_memory_mb", p.max_memory_mb);
}

const char* type_name(const json& j) { return j.type_name(); }

template <class T>
void read_value(const json& j, const std::string& key, T& out) {
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
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!j.is_string()) throw InputError(key + ": expected a string, got " + type_name(j));
    out = j.get<std::string>();
  } else if constexpr (std::is_same_v<T, std::optional<double>>) {
    if (j.is_null()) {
      out.reset();
    } else {
      double v;
      read_value(j, key, v);
      out = v;
    }
  } else if constexpr (std::is_same_v<T, OptimizationOptions>) {
    if (!j.is_object()) throw InputError(key + ": expected an object of stage-6 options");
    for (auto it = j.begin(); it != j.end(); ++it) {
      const auto& fields = optimization_fields();
      const auto f = std::find_if(fields.begin(), fields.end(),
                                  [&](const OptimizationField& f) { return f.key == it.key(); });
      const std::string name = key + "." + it.key();
      if (f == fields.end()) throw InputError("unknown parameter '" + name + "'");
      visit_field(*f, out, [&](auto& member) { read_value(*it, name, member); });
    }
  } else {  // label list: "all" or an array of integers
    if (j.is_string() && j.get<std::string>() == "all") {
      out.clear();
      return;
    }
    if (!j.is_array()) throw InputError(key + ": expected \"all\" or a list of integer labels");
    out.clear();
    for (const json& item : j) {
      std::int64_t v;
      read_value(item, key, v);
      out.push_back(v);
    }
  }
}

void require(bool ok, const char* key, const char* what) {
  if (!ok) throw InputError(std::string(key) + ": " + what);
}

}  // namespace

void validate(const Parameters& p) {
  auto finite = [](double v) { return std::isfinite(v); };
  require(!p.iso || finite(*p.iso), "iso", "must be a finite number");
  require(p.margin_voxels >= 1 && p.margin_voxels <= 64, "margin_voxels", "must be in 1..64");
  require(finite(p.min_component_fraction) && p.min_component_fraction >= 0 &&
              p.min_component_fraction <= 1,
          "min_component_fraction", "must be in [0, 1]");
  require(finite(p.smoothing_sigma_mm) && p.smoothing_sigma_mm >= 0, "smoothing_sigma_mm",
          "must be >= 0 (0 = auto)");
  require(finite(p.medial_min_separation_mm) && p.medial_min_separation_mm >= 0,
          "medial_min_separation_mm", "must be >= 0 (0 = auto)");
  require(finite(p.medial_min_angle_deg) && p.medial_min_angle_deg >= 0 &&
              p.medial_min_angle_deg <= 180,
          "medial_min_angle_deg", "must be in [0, 180]");
  require(finite(p.lfs_min_mm) && p.lfs_min_mm >= 0, "lfs_min_mm", "must be >= 0 (0 = auto)");
  require(finite(p.lfs_max_mm) && p.lfs_max_mm >= 0, "lfs_max_mm", "must be >= 0 (0 = auto)");
  require(p.lfs_max_mm == 0 || p.lfs_max_mm >= p.lfs_min_mm, "lfs_max_mm",
          "must not be below lfs_min_mm");
  require(finite(p.r) && p.r > 0 && p.r < 1, "r", "must be in (0, 1)");
  require(finite(p.sigma_surface_mm) && p.sigma_surface_mm > 0, "sigma_surface_mm", "must be > 0");
  require(finite(p.sigma_density_mm) && p.sigma_density_mm >= 0, "sigma_density_mm",
          "must be >= 0 (0 = auto)");
  require(finite(p.interior_spacing_mm) && p.interior_spacing_mm >= 0, "interior_spacing_mm",
          "must be >= 0 (0 = auto)");
  require(p.interior_points >= 0, "interior_points", "must be >= 0 (0 = from the spacing)");
  require(finite(p.epsilon_mm) && p.epsilon_mm >= 0, "epsilon_mm", "must be >= 0 (0 = auto)");
  require(p.max_iterations >= 0 && p.max_iterations <= 100000, "max_iterations",
          "must be in 0..100000");
  require(p.fidelity_rounds >= 0 && p.fidelity_rounds <= 10, "fidelity_rounds", "must be in 0..10");
  require(finite(p.fidelity_tolerance_mm) && p.fidelity_tolerance_mm >= 0, "fidelity_tolerance_mm",
          "must be >= 0 (0 = auto)");
  require(p.optimize == "none" || p.optimize == "default", "optimize",
          "must be \"none\" or \"default\"");
  validate(p.optimization);
  require(p.threads >= 0 && p.threads <= 1024, "threads", "must be in 0..1024 (0 = all cores)");
  require(p.max_points > 0, "max_points", "must be > 0");
  require(finite(p.max_memory_mb) && p.max_memory_mb >= 0, "max_memory_mb",
          "must be >= 0 (0 = available memory)");
}

json to_json(const Parameters& parameters) {
  Parameters p = parameters;
  json j = json::object();
  for_each_field(p, [&](const char* key, auto& value) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_same_v<T, std::optional<double>>)
      j[key] = value ? json(*value) : json(nullptr);
    else if constexpr (std::is_same_v<T, std::vector<std::int64_t>>)
      j[key] = value.empty() ? json("all") : json(value);
    else if constexpr (std::is_same_v<T, OptimizationOptions>)
      for (const OptimizationField& f : optimization_fields())
        visit_field(f, value, [&](const auto& member) { j[key][std::string(f.key)] = member; });
    else
      j[key] = value;
  });
  return j;
}

Parameters parameters_from_json(const json& j, const Parameters& base) {
  if (!j.is_object()) throw InputError("preset: expected a JSON object of parameters");
  Parameters p = base;
  std::vector<std::string> known;
  for_each_field(p, [&](const char* key, auto& value) {
    known.push_back(key);
    if (auto it = j.find(key); it != j.end()) read_value(*it, key, value);
  });
  for (auto it = j.begin(); it != j.end(); ++it)
    if (std::find(known.begin(), known.end(), it.key()) == known.end())
      throw InputError("unknown parameter '" + it.key() + "'");
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
