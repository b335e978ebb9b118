// The one way the CLI (`cvtmesh mesh -o`) and the viewer (File > Export) write a finished
// mesh, so both give the same file for the same mesh.
#pragma once

#include <string>

#include "base/tet_mesh.h"

namespace cvt {

// write_mesh with the per-tet quality measures as cell data (V/r_mc³, gradient error, condition
// number, smallest dihedral angle, each under its measure_key), so a .vtu can be coloured by
// them; formats without cell data ignore them. Throws InputError naming the path.
void write_mesh_with_quality(const TetMesh& mesh, const std::string& path);

}  // namespace cvt
