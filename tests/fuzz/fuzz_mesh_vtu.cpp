// VTK XML UnstructuredGrid (.vtu) through read_mesh, as `cvtmesh quality` reads it.
#include "fuzz_input.h"
#include "io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return cvt::fuzz::run_on_file(data, size, ".vtu",
                                [](const std::string& path) { cvt::read_mesh(path); });
}
