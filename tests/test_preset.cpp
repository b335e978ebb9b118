// Presets: JSON round trip and one clear line for every bad key, type or value.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "base/errors.h"
#include "pipeline/preset.h"

using namespace cvt;
namespace fs = std::filesystem;

namespace {

std::string error_of(const nlohmann::json& j) {
  try {
    parameters_from_json(j);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("cvtmesh_preset_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

}  // namespace

TEST(Preset, RoundTripThroughAFile) {
  Parameters p;
  p.labels = {127, 255};
  p.iso = 2.9;
  p.inside_above = false;
  p.r = 0.35;
  p.max_iterations = 17;
  p.seed = 123456789012345ULL;
  p.optimize = OptimizeMode::none;  // not the default
  p.optimization.target_dihedral_deg = 17.5;
  p.optimization.odt_passes = 1;
  p.optimization.boundary_flips = false;
  const fs::path file = temp_dir() / "preset.json";
  save_preset(p, file.string());
  EXPECT_EQ(load_preset(file.string()), p);
  // Keys absent from a preset keep the base values.
  Parameters base;
  base.r = 0.4;
  EXPECT_EQ(parameters_from_json(nlohmann::json{{"seed", 7}}, base).r, 0.4);
  EXPECT_EQ(parameters_from_json(nlohmann::json{{"labels", "all"}}).labels.size(), 0u);
  // Stage 6's options: a partial object changes only what it names.
  const Parameters o =
      parameters_from_json(nlohmann::json::parse(R"({"optimization": {"max_passes": 3}})"));
  EXPECT_EQ(o.optimization.max_passes, 3);
  EXPECT_EQ(o.optimization.target_dihedral_deg, OptimizationOptions{}.target_dihedral_deg);
  fs::remove_all(file.parent_path());
}

TEST(Preset, BadKeysTypesAndValuesNameTheKey) {
  EXPECT_NE(error_of({{"radius", 0.5}}).find("unknown parameter 'radius'"), std::string::npos);
  EXPECT_NE(error_of({{"r", "big"}}).find("r: expected a number"), std::string::npos);
  EXPECT_NE(error_of({{"r", -0.5}}).find("r: must be in (0, 1)"), std::string::npos);
  EXPECT_NE(error_of({{"sigma_surface_mm", 0}}).find("sigma_surface_mm"), std::string::npos);
  EXPECT_NE(error_of({{"epsilon_mm", -1}}).find("epsilon_mm"), std::string::npos);
  EXPECT_NE(error_of({{"max_iterations", 2.5}}).find("max_iterations: expected an integer"),
            std::string::npos);
  EXPECT_NE(error_of({{"seed", -3}}).find("seed: must not be negative"), std::string::npos);
  // Integers beyond the parameter's type are refused, not wrapped (2^32 + 1 threads is not 1).
  EXPECT_NE(error_of({{"threads", 4294967297LL}}).find("threads: 4294967297 is out of range"),
            std::string::npos);
  EXPECT_NE(error_of({{"max_iterations", -4294967296LL}}).find("out of range"), std::string::npos);
  EXPECT_NE(error_of({{"interior_points", 18446744073709551615ULL}}).find("out of range"),
            std::string::npos);
  EXPECT_NE(error_of({{"labels", {1, "x"}}}).find("labels"), std::string::npos);
  EXPECT_NE(error_of({{"optimize", "fast"}}).find("optimize"), std::string::npos);
  using nlohmann::json;
  EXPECT_NE(error_of(json::parse(R"({"optimization": {"passes": 3}})"))
                .find("unknown parameter 'optimization.passes'"),
            std::string::npos);
  EXPECT_NE(error_of(json::parse(R"({"optimization": {"max_passes": 2.5}})"))
                .find("optimization.max_passes: expected an integer"),
            std::string::npos);
  EXPECT_NE(error_of(json::parse(R"({"optimization": {"target_dihedral_deg": -5}})"))
                .find("optimization.target_dihedral_deg: must be in [1, 35]"),
            std::string::npos);
  EXPECT_NE(error_of(json::parse(R"({"optimization": {"flips": 1}})"))
                .find("optimization.flips: expected true or false"),
            std::string::npos);
  EXPECT_NE(error_of(json::parse(R"({"optimization": 3})")).find("optimization: expected an object"),
            std::string::npos);
  EXPECT_NE(error_of({{"lfs_min_mm", 3}, {"lfs_max_mm", 2}}).find("lfs_max_mm"), std::string::npos);
  EXPECT_NE(error_of(nlohmann::json::array()).find("expected a JSON object"), std::string::npos);
}

TEST(Preset, BadFilesNameThePath) {
  const fs::path dir = temp_dir();
  const fs::path garbage = dir / "garbage.json";
  std::ofstream(garbage) << "{ \"r\": 0.5,";
  try {
    load_preset(garbage.string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(garbage.string()), std::string::npos);
  }
  // A number beyond double is a JSON error too, not a crash (found by fuzz_preset).
  const fs::path overflow = dir / "overflow.json";
  std::ofstream(overflow) << "{\"epsilon_mm\": 1e999}";
  try {
    load_preset(overflow.string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(overflow.string() + ": not valid JSON"),
              std::string::npos);
  }
  EXPECT_THROW(load_preset((dir / "missing.json").string()), InputError);
  // Writing into a missing folder fails cleanly and leaves nothing behind.
  EXPECT_THROW(save_preset(Parameters{}, (dir / "no" / "such" / "p.json").string()), InputError);
  EXPECT_FALSE(fs::exists(dir / "no"));
  fs::remove_all(dir);
}
