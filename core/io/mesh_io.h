// Tetrahedral meshes in and out of files. The format follows the extension, and labels
// (subdomains, 1 when the mesh has none) go where each format keeps them:
//   .mesh  Medit (MeshVersionFormatted 2): tet refs = labels; Triangles = the boundary, ref =
//          the label of its tet
//   .vtu   VTK XML: cell data "label" plus MeshWriteOptions::cell_data
//   .msh   Gmsh 4.1 ASCII: a volume per label (physical "label_<L>") and a surface of its
//          boundary triangles (physical "boundary_<L>")
//   .inp   Abaqus: C3D4 elements in ELSET SUBDOMAIN_<L> (M for minus); surface BOUNDARY
//   .feb   FEBio 4.0 mesh: Elements "subdomain_<L>" (tet4) and Surface "boundary" (tri3)
//   .node/.ele  TetGen, 1-based, both written; region attribute = label
//   .stl (binary, float32) / .ply (binary, double) / .obj: the boundary surface only
// Every write goes to a temp file beside the target that is renamed onto it, so a failure
// never leaves a partial file; failures and bad files throw InputError naming the path.
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/tet_mesh.h"

namespace cvt {

struct MeshWriteOptions {
  // Extra per-tet scalars (e.g. quality measures), one vector per name with one value per
  // tet, written as cell data by .vtu; the other formats have no place for them.
  std::vector<std::pair<std::string, std::vector<double>>> cell_data;
  bool vtu_ascii = false;  // .vtu as ASCII text instead of inline base64 binary
};

// Writes `mesh` in the format named by the extension of `path` (case-insensitive).
// Coordinates are written exactly (shortest round-trip decimals or raw doubles), except in
// .stl, which stores 32-bit floats by definition.
void write_mesh(const TetMesh& mesh, const std::string& path, const MeshWriteOptions& options = {});

// Reads a .mesh (Medit ASCII) or .vtu (VTK XML UnstructuredGrid: ascii, base64 or raw
// appended, uncompressed or zlib) file. Only tetrahedra are kept (other cells are ignored);
// tets with negative orientation are reoriented. Labels come from the Medit refs or a .vtu
// cell array named label(s), medit:ref, gmsh:physical, CellEntityIds, MaterialIds or
// subdomain; when every label is 1 they are left empty. Unsupported: binary .meshb, VTK
// compressors other than zlib (LZ4, LZMA), legacy .vtk.
TetMesh read_mesh(const std::string& path);

// The extensions write_mesh and read_mesh accept, e.g. ".mesh".
const std::vector<std::string>& mesh_write_extensions();
const std::vector<std::string>& mesh_read_extensions();
// Whether the format of `path` stores MeshWriteOptions::cell_data (only .vtu does).
bool mesh_format_has_cell_data(const std::string& path);

namespace detail {  // shared by mesh_io.cpp, mesh_writers.cpp and mesh_readers.cpp

// Buffered output to a temp file beside `path`; commit() renames it onto `path`. Destroyed
// without commit (an exception, an early return) it deletes the temp file.
class AtomicOutput {
 public:
  explicit AtomicOutput(std::string path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  AtomicOutput& operator<<(std::string_view text);
  AtomicOutput& operator<<(const char* text) { return *this << std::string_view(text); }
  AtomicOutput& operator<<(char c);
  AtomicOutput& operator<<(double value);  // shortest text that reads back exactly
  AtomicOutput& operator<<(std::int64_t value);
  AtomicOutput& operator<<(std::int32_t value) { return *this << std::int64_t{value}; }
  AtomicOutput& operator<<(std::size_t value) { return *this << std::int64_t(value); }
  void bytes(const void* data, std::size_t size);

  // Flushes and closes the temp file (so several outputs can all be finished before any is
  // renamed), then commit() renames it onto the target.
  void finish();
  void commit();
  // Throws InputError("cannot write <path>: <reason>") after deleting the temp file.
  [[noreturn]] void fail(const std::string& reason);
  const std::string& path() const { return path_; }

 private:
  void flush();
  std::string path_, temp_path_;
  std::FILE* file_ = nullptr;
  std::vector<char> buffer_;
  std::size_t used_ = 0;
  bool committed_ = false;
};

// Writers, one per format, each given an open output (or two for TetGen).
void write_medit(const TetMesh& mesh, AtomicOutput& out);
void write_vtu(const TetMesh& mesh, const MeshWriteOptions& options, AtomicOutput& out);
void write_gmsh(const TetMesh& mesh, AtomicOutput& out);
void write_abaqus(const TetMesh& mesh, AtomicOutput& out);
void write_febio(const TetMesh& mesh, AtomicOutput& out);
void write_tetgen(const TetMesh& mesh, AtomicOutput& node_out, AtomicOutput& ele_out);
void write_stl(const TetMesh& mesh, AtomicOutput& out);
void write_ply(const TetMesh& mesh, AtomicOutput& out);
void write_obj(const TetMesh& mesh, AtomicOutput& out);

// The whole token as a number (a leading '+' is accepted), else nullopt.
std::optional<double> parse_double(std::string_view token);
std::optional<std::int64_t> parse_int(std::string_view token);

// Readers, given the whole file; `path` is for messages only.
TetMesh read_medit(const std::string& path, std::string_view text);
TetMesh read_vtu(const std::string& path, std::string_view text);
// Checks indices and coordinates, reorients negative tets and drops all-1 labels; throws
// InputError naming `path`.
void finish_read_mesh(const std::string& path, TetMesh& mesh);

}  // namespace detail
}  // namespace cvt
