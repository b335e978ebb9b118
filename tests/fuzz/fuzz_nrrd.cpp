// NRRD (.nrrd, attached data in any encoding) through read_image, as `cvtmesh info`/`mesh` read it.
#include "fuzz_input.h"
#include "io/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return cvt::fuzz::run_on_file(data, size, ".nrrd",
                                [](const std::string& path) { cvt::read_image(path); });
}
