// The fuzz build reads and never writes meshes, and clang 14 cannot compile
// core/mesh_writers.cpp (a C++20 lambda capture of a structured binding). These stand in for
// its writers so that mesh_io.cpp links; reaching one is a bug in a fuzz target.
#include <stdexcept>

#include "io/mesh_io.h"

namespace cvt::detail {
namespace {
[[noreturn]] void not_in_fuzz_build() {
  throw std::logic_error("mesh writers are not part of the fuzz build");
}
}  // namespace

void write_medit(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_vtu(const TetMesh&, const MeshWriteOptions&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_gmsh(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_abaqus(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_febio(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_tetgen(const TetMesh&, AtomicOutput&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_stl(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_ply(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}
void write_obj(const TetMesh&, AtomicOutput&) {
  not_in_fuzz_build();
}

}  // namespace cvt::detail
