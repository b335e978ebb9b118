// INRIMAGE-4 (.inr, .inr.gz when gzip) through read_image, as `cvtmesh info`/`mesh` read it.
#include "fuzz_input.h"
#include "io/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return cvt::fuzz::run_on_file(data, size, cvt::fuzz::is_gzip(data, size) ? ".inr.gz" : ".inr",
                                [](const std::string& path) { cvt::read_image(path); });
}
