// One writer per output format. The mesh was checked by write_mesh (indices in range, finite
// coordinates, label and cell data sizes), so writers only format. Text formats use the
// shortest decimals that read back exactly; labels default to 1.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdlib>
#include <cstring>
#include <map>
#include <type_traits>

#include "io/mesh_io.h"

namespace cvt::detail {
namespace {

// Binary formats here are little endian; writing native bytes is then only correct on a
// little-endian host (x86-64, ARM64), which is all we build for.
static_assert(std::endian::native == std::endian::little,
              "binary mesh writers assume little endian");

std::int32_t label_of(const TetMesh& mesh, std::size_t t) {
  return mesh.labels.empty() ? 1 : mesh.labels[t];
}

// Tet indices grouped by label: labels ascending, tets in mesh order.
std::vector<std::pair<std::int32_t, std::vector<std::size_t>>> tets_by_label(const TetMesh& mesh) {
  std::map<std::int32_t, std::vector<std::size_t>> groups;
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) groups[label_of(mesh, t)].push_back(t);
  return {groups.begin(), groups.end()};
}

// The boundary as a standalone surface: the vertices it uses (in mesh order) and triangles
// indexing them, so surface files carry no unused interior vertices.
struct Surface {
  std::vector<Vec3> vertices;
  std::vector<Triangle> triangles;
};

Surface boundary_surface(const TetMesh& mesh) {
  Surface s;
  s.triangles = boundary_triangles(mesh);
  std::vector<std::int32_t> new_index(mesh.vertices.size(), -1);
  for (const Triangle& t : s.triangles) {
    for (std::int32_t v : t) new_index[v] = 0;
  }
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    if (new_index[v] == 0) {
      new_index[v] = std::int32_t(s.vertices.size());
      s.vertices.push_back(mesh.vertices[v]);
    }
  }
  for (Triangle& t : s.triangles) {
    for (std::int32_t& v : t) v = new_index[v];
  }
  return s;
}

// Streams base64 (RFC 4648, no line breaks) into `out`, three bytes at a time.
class Base64Writer {
 public:
  explicit Base64Writer(AtomicOutput& out) : out_(out) {}
  template <typename T>
  void add(const T& value) {
    const auto* p = reinterpret_cast<const unsigned char*>(&value);
    for (std::size_t i = 0; i < sizeof(T); ++i) add_byte(p[i]);
  }
  void finish() {
    if (pending_ > 0) {
      for (int i = pending_; i < 3; ++i) group_[i] = 0;
      char quad[4];
      encode(quad);
      if (pending_ == 1) quad[2] = '=';
      quad[3] = '=';
      out_ << std::string_view(quad, 4);
      pending_ = 0;
    }
  }

 private:
  void add_byte(unsigned char b) {
    group_[pending_++] = b;
    if (pending_ == 3) {
      char quad[4];
      encode(quad);
      out_ << std::string_view(quad, 4);
      pending_ = 0;
    }
  }
  void encode(char* quad) const {
    static constexpr char kAlphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const unsigned v = unsigned(group_[0]) << 16 | unsigned(group_[1]) << 8 | group_[2];
    for (int i = 0; i < 4; ++i) quad[i] = kAlphabet[(v >> (18 - 6 * i)) & 63];
  }
  AtomicOutput& out_;
  unsigned char group_[3] = {0, 0, 0};
  int pending_ = 0;
};

// One VTK DataArray of `count` values produced by value(i), as ASCII or as inline base64
// (a UInt64 byte count, then the raw values, encoded together as meshio and VTK read them).
template <typename T, typename ValueAt>
void vtu_array(AtomicOutput& out, bool ascii, const char* type, const std::string& name,
               int components, std::size_t count, ValueAt value) {
  out << "        <DataArray type=\"" << type << "\" Name=\"" << name << '"';
  if (components > 1) out << " NumberOfComponents=\"" << std::int64_t{components} << '"';
  out << " format=\"" << (ascii ? "ascii" : "binary") << "\">\n";
  if (ascii) {
    for (std::size_t i = 0; i < count; ++i) {
      if constexpr (std::is_floating_point_v<T>) {
        out << double(value(i));
      } else {
        out << std::int64_t(value(i));
      }
      out << ((i + 1) % 12 == 0 || i + 1 == count ? '\n' : ' ');
    }
  } else {
    Base64Writer b64(out);
    b64.add(std::uint64_t(count * sizeof(T)));
    for (std::size_t i = 0; i < count; ++i) b64.add(T(value(i)));
    b64.finish();
    out << '\n';
  }
  out << "        </DataArray>\n";
}

std::string xml_escaped(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '&')
      r += "&amp;";
    else if (c == '<')
      r += "&lt;";
    else if (c == '>')
      r += "&gt;";
    else if (c == '"')
      r += "&quot;";
    else
      r += c;
  }
  return r;
}

}  // namespace

void write_medit(const TetMesh& mesh, AtomicOutput& out) {
  // Version 2 announces double precision; readers (meshio included) parse version 1
  // coordinates as 32-bit floats.
  out << "MeshVersionFormatted 2\nDimension 3\n\nVertices\n" << mesh.vertices.size() << '\n';
  for (const Vec3& p : mesh.vertices) out << p.x << ' ' << p.y << ' ' << p.z << " 0\n";
  out << "\nTetrahedra\n" << mesh.tets.size() << '\n';
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    for (std::int32_t v : mesh.tets[t]) out << v + 1 << ' ';
    out << label_of(mesh, t) << '\n';
  }
  const std::vector<std::int64_t> faces = boundary_faces(mesh);
  out << "\nTriangles\n" << faces.size() << '\n';
  for (std::int64_t f : faces) {
    const Triangle triangle = outward_faces(mesh.tets[f / 4])[f % 4];
    for (std::int32_t v : triangle) out << v + 1 << ' ';
    out << label_of(mesh, std::size_t(f / 4)) << '\n';
  }
  out << "\nEnd\n";
}

void write_vtu(const TetMesh& mesh, const MeshWriteOptions& options, AtomicOutput& out) {
  const bool ascii = options.vtu_ascii;
  const std::size_t n = mesh.vertices.size(), m = mesh.tets.size();
  out << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\""
      << n << "\" NumberOfCells=\"" << m << "\">\n      <Points>\n";
  vtu_array<double>(out, ascii, "Float64", "Points", 3, 3 * n,
                    [&](std::size_t i) { return mesh.vertices[i / 3][int(i % 3)]; });
  out << "      </Points>\n      <Cells>\n";
  vtu_array<std::int32_t>(out, ascii, "Int32", "connectivity", 1, 4 * m,
                          [&](std::size_t i) { return mesh.tets[i / 4][i % 4]; });
  vtu_array<std::int64_t>(out, ascii, "Int64", "offsets", 1, m,
                          [&](std::size_t i) { return std::int64_t(4 * (i + 1)); });
  constexpr std::uint8_t kVtkTetra = 10;
  vtu_array<std::uint8_t>(out, ascii, "UInt8", "types", 1, m,
                          [&](std::size_t) { return kVtkTetra; });
  out << "      </Cells>\n      <CellData Scalars=\"label\">\n";
  vtu_array<std::int32_t>(out, ascii, "Int32", "label", 1, m,
                          [&](std::size_t t) { return label_of(mesh, t); });
  for (const auto& [name, values] : options.cell_data) {
    vtu_array<double>(out, ascii, "Float64", xml_escaped(name), 1, m,
                      [&](std::size_t t) { return values[t]; });
  }
  out << "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
}

void write_gmsh(const TetMesh& mesh, AtomicOutput& out) {
  // One volume entity per label (tag = rank + 1) and one surface entity holding that label's
  // boundary triangles. Physical tags are the labels when all are positive (gmsh wants
  // positive tags), else rank + 1; $PhysicalNames keeps the label either way.
  const auto groups = tets_by_label(mesh);
  const std::size_t k = groups.size();
  const bool positive = groups.front().first > 0;
  std::map<std::int32_t, std::size_t> rank;
  for (std::size_t r = 0; r < k; ++r) rank[groups[r].first] = r;
  const std::vector<std::int64_t> faces = boundary_faces(mesh);
  std::vector<std::vector<std::size_t>> tris_of(k);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    tris_of[rank[label_of(mesh, faces[f] / 4)]].push_back(f);
  }
  const auto physical = [&](std::size_t r) {
    return positive ? std::int64_t(groups[r].first) : std::int64_t(r + 1);
  };
  const auto triangle = [&](std::size_t f) {
    return outward_faces(mesh.tets[faces[f] / 4])[faces[f] % 4];
  };
  std::size_t num_surfaces = 0;
  for (std::size_t r = 0; r < k; ++r) num_surfaces += !tris_of[r].empty();

  out << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n" << num_surfaces + k << '\n';
  for (std::size_t r = 0; r < k; ++r) {
    if (!tris_of[r].empty())
      out << "2 " << physical(r) << " \"boundary_" << groups[r].first << "\"\n";
  }
  for (std::size_t r = 0; r < k; ++r)
    out << "3 " << physical(r) << " \"label_" << groups[r].first << "\"\n";
  out << "$EndPhysicalNames\n$Entities\n0 0 " << num_surfaces << ' ' << k << '\n';
  const auto entity = [&](std::size_t r, int dim, const std::vector<std::size_t>& items) {
    Vec3 lo = mesh.vertices[mesh.tets[groups[r].second[0]][0]], hi = lo;
    const auto grow = [&](std::int32_t v) {
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], mesh.vertices[v][a]);
        hi[a] = std::max(hi[a], mesh.vertices[v][a]);
      }
    };
    for (std::size_t item : items) {
      if (dim == 3) {
        for (std::int32_t v : mesh.tets[item]) grow(v);
      } else {
        for (std::int32_t v : triangle(item)) grow(v);
      }
    }
    out << r + 1 << ' ' << lo.x << ' ' << lo.y << ' ' << lo.z << ' ' << hi.x << ' ' << hi.y << ' '
        << hi.z << " 1 " << physical(r) << " 0\n";
  };
  for (std::size_t r = 0; r < k; ++r) {
    if (!tris_of[r].empty()) entity(r, 2, tris_of[r]);
  }
  for (std::size_t r = 0; r < k; ++r) entity(r, 3, groups[r].second);
  out << "$EndEntities\n";

  // All nodes in one block on the first volume; gmsh accepts nodes used by other entities.
  const std::size_t n = mesh.vertices.size();
  out << "$Nodes\n1 " << n << " 1 " << n << "\n3 1 0 " << n << '\n';
  for (std::size_t v = 0; v < n; ++v) out << v + 1 << '\n';
  for (const Vec3& p : mesh.vertices) out << p.x << ' ' << p.y << ' ' << p.z << '\n';
  out << "$EndNodes\n$Elements\n"
      << num_surfaces + k << ' ' << mesh.tets.size() + faces.size() << " 1 "
      << mesh.tets.size() + faces.size() << '\n';
  for (std::size_t r = 0; r < k; ++r) {  // tet t keeps element tag t + 1
    out << "3 " << r + 1 << " 4 " << groups[r].second.size() << '\n';
    for (std::size_t t : groups[r].second) {
      out << t + 1;
      for (std::int32_t v : mesh.tets[t]) out << ' ' << v + 1;
      out << '\n';
    }
  }
  for (std::size_t r = 0; r < k; ++r) {
    if (tris_of[r].empty()) continue;
    out << "2 " << r + 1 << " 2 " << tris_of[r].size() << '\n';
    for (std::size_t f : tris_of[r]) {
      out << mesh.tets.size() + f + 1;
      for (std::int32_t v : triangle(f)) out << ' ' << v + 1;
      out << '\n';
    }
  }
  out << "$EndElements\n";
}

void write_abaqus(const TetMesh& mesh, AtomicOutput& out) {
  out << "*HEADING\ncvtmesh tetrahedral mesh, units mm\n*NODE\n";
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3& p = mesh.vertices[v];
    out << v + 1 << ", " << p.x << ", " << p.y << ", " << p.z << '\n';
  }
  // One element block per label, named SUBDOMAIN_<label>; element ids stay tet index + 1.
  for (const auto& [label, tets] : tets_by_label(mesh)) {
    out << "*ELEMENT, TYPE=C3D4, ELSET=SUBDOMAIN_" << (label < 0 ? "M" : "")
        << std::abs(std::int64_t(label)) << '\n';
    for (std::size_t t : tets) {
      out << t + 1;
      for (std::int32_t v : mesh.tets[t]) out << ", " << v + 1;
      out << '\n';
    }
  }
  // The boundary as an element-based surface; Abaqus C3D4 faces are S1 = 1-2-3, S2 = 1-4-2,
  // S3 = 2-4-3, S4 = 3-4-1, i.e. outward_faces 0..3 are S3, S4, S2, S1.
  static constexpr const char* kAbaqusFace[4] = {"S3", "S4", "S2", "S1"};
  out << "*SURFACE, TYPE=ELEMENT, NAME=BOUNDARY\n";
  for (std::int64_t f : boundary_faces(mesh))
    out << f / 4 + 1 << ", " << kAbaqusFace[f % 4] << '\n';
}

void write_febio(const TetMesh& mesh, AtomicOutput& out) {
  // Mesh only (FEBio 4.0 spec): materials, domains and loads are the user's to add. Element
  // ids run 1, 2, ... in the order written (grouped by label), as FEBio expects.
  out << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<febio_spec version=\"4.0\">\n"
         "  <Mesh>\n    <Nodes name=\"nodes\">\n";
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3& p = mesh.vertices[v];
    out << "      <node id=\"" << v + 1 << "\">" << p.x << ',' << p.y << ',' << p.z << "</node>\n";
  }
  out << "    </Nodes>\n";
  std::int64_t id = 0;
  for (const auto& [label, tets] : tets_by_label(mesh)) {
    out << "    <Elements type=\"tet4\" name=\"subdomain_" << label << "\">\n";
    for (std::size_t t : tets) {
      const Tet& tet = mesh.tets[t];
      out << "      <elem id=\"" << ++id << "\">" << tet[0] + 1 << ',' << tet[1] + 1 << ','
          << tet[2] + 1 << ',' << tet[3] + 1 << "</elem>\n";
    }
    out << "    </Elements>\n";
  }
  out << "    <Surface name=\"boundary\">\n";
  id = 0;
  for (const Triangle& t : boundary_triangles(mesh)) {
    out << "      <tri3 id=\"" << ++id << "\">" << t[0] + 1 << ',' << t[1] + 1 << ',' << t[2] + 1
        << "</tri3>\n";
  }
  out << "    </Surface>\n  </Mesh>\n</febio_spec>\n";
}

void write_tetgen(const TetMesh& mesh, AtomicOutput& node_out, AtomicOutput& ele_out) {
  // 1-based, single spaces and no comments after the header: meshio's reader needs that.
  node_out << "# cvtmesh: <#points> 3 <#attributes> <#markers>, then index x y z (mm)\n"
           << mesh.vertices.size() << " 3 0 0\n";
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3& p = mesh.vertices[v];
    node_out << v + 1 << ' ' << p.x << ' ' << p.y << ' ' << p.z << '\n';
  }
  ele_out << "# cvtmesh: <#tets> 4 <#attributes>, then index, 4 nodes, region label\n"
          << mesh.tets.size() << " 4 1\n";
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    ele_out << t + 1;
    for (std::int32_t v : mesh.tets[t]) ele_out << ' ' << v + 1;
    ele_out << ' ' << label_of(mesh, t) << '\n';
  }
}

void write_stl(const TetMesh& mesh, AtomicOutput& out) {
  const std::vector<Triangle> triangles = boundary_triangles(mesh);
  // The header must not start with "solid", or readers take the file for ASCII STL.
  char header[80] = {};
  std::strncpy(header, "cvtmesh boundary surface, binary STL, mm", sizeof header - 1);
  out.bytes(header, sizeof header);
  const std::uint32_t count = std::uint32_t(triangles.size());
  out.bytes(&count, 4);
  for (const Triangle& t : triangles) {
    const Vec3 &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    const Vec3 normal = cross(b - a, c - a);
    const double length = norm(normal);
    const Vec3 unit = length > 0 ? normal / length : Vec3{};
    std::array<float, 12> record;
    for (int i = 0; i < 3; ++i) {
      record[i] = float(unit[i]);
      record[3 + i] = float(a[i]);
      record[6 + i] = float(b[i]);
      record[9 + i] = float(c[i]);
    }
    out.bytes(record.data(), sizeof record);
    const std::uint16_t attribute = 0;
    out.bytes(&attribute, 2);
  }
}

void write_ply(const TetMesh& mesh, AtomicOutput& out) {
  // Binary with double coordinates, so the surface keeps the mesh's exact positions.
  const Surface s = boundary_surface(mesh);
  out << "ply\nformat binary_little_endian 1.0\ncomment cvtmesh boundary surface, mm\n"
         "element vertex "
      << s.vertices.size()
      << "\nproperty double x\nproperty double y\nproperty double z\nelement face "
      << s.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Vec3& p : s.vertices) {
    const double xyz[3] = {p.x, p.y, p.z};
    out.bytes(xyz, sizeof xyz);
  }
  for (const Triangle& t : s.triangles) {
    const std::uint8_t three = 3;
    out.bytes(&three, 1);
    out.bytes(t.data(), 3 * sizeof(std::int32_t));
  }
}

void write_obj(const TetMesh& mesh, AtomicOutput& out) {
  const Surface s = boundary_surface(mesh);
  out << "# cvtmesh boundary surface, mm\n";
  for (const Vec3& p : s.vertices) out << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
  for (const Triangle& t : s.triangles)
    out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
}

}  // namespace cvt::detail
