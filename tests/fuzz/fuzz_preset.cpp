// Parameter presets (JSON) through load_preset, as `--preset` reads them.
#include "fuzz_input.h"
#include "pipeline/preset.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return cvt::fuzz::run_on_file(data, size, ".json",
                                [](const std::string& path) { cvt::load_preset(path); });
}
