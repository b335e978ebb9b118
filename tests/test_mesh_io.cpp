// Mesh files: every format written and read back by independent readers (meshio, gmsh),
// exact round trips through our own readers, hostile inputs, failed writes, determinism.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "base/errors.h"
#include "io/mesh_io.h"

using namespace cvt;
namespace fs = std::filesystem;

namespace {

const std::string kChecker = std::string(CVTMESH_SOURCE_DIR) + "/tests/mesh_roundtrip.py";

// An nx × ny × nz block of cubes of side h at `origin`, each cut into the 6 Kuhn tets along
// its main diagonal (so neighbouring cubes share faces); cubes with x index ≥ split_x get
// label 2, the others label 1.
TetMesh kuhn_block(int nx, int ny, int nz, double h, Vec3 origin, int split_x) {
  TetMesh m;
  const auto index = [&](int i, int j, int k) {
    return std::int32_t((k * (ny + 1) + j) * (nx + 1) + i);
  };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) m.vertices.push_back(origin + Vec3{i * h, j * h, k * h});
  const int axes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& order : axes) {
          int c[3] = {i, j, k};
          Tet t;
          t[0] = index(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[order[s]];
            t[s + 1] = index(c[0], c[1], c[2]);
          }
          if (signed_volume(m, t) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
          m.labels.push_back(i >= split_x ? 2 : 1);
        }
  return m;
}

// Two cubes side by side, labels 1 and 2, with coordinates that are not short decimals.
TetMesh two_cubes() {
  return kuhn_block(2, 1, 1, 1.0 / 3.0, Vec3{0.1, -2.3, 1e-7}, 1);
}

double total_volume(const TetMesh& m) {
  double v = 0;
  for (const Tet& t : m.tets) v += signed_volume(m, t);
  return v;
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string bounds_option(const TetMesh& m) {
  Vec3 lo = m.vertices[0], hi = lo;
  for (const Vec3& p : m.vertices)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  return " --bounds " + fmt(lo.x) + ' ' + fmt(lo.y) + ' ' + fmt(lo.z) + ' ' + fmt(hi.x) + ' ' +
         fmt(hi.y) + ' ' + fmt(hi.z);
}

int run(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int check_with_meshio(const std::string& file, std::size_t vertices, std::size_t cells,
                      double volume, const std::string& options = "") {
  return run("/usr/bin/python3 '" + kChecker + "' '" + file + "' " + std::to_string(vertices) +
             ' ' + std::to_string(cells) + ' ' + fmt(volume) + options);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void spit(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

class MeshIo : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("cvtmesh_mesh_io_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_ / "readonly", fs::perms::owner_all, ec);
    fs::remove_all(dir_, ec);
  }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// The error raised by read_mesh(path), or "" when it succeeds.
std::string read_error(const std::string& path) {
  try {
    read_mesh(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

void expect_same(const TetMesh& a, const TetMesh& b) {
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.labels, b.labels);
}

}  // namespace

TEST(BoundaryTriangles, SingleTetGivesItsFourOutwardFaces) {
  TetMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}};
  const auto faces = outward_faces(m.tets[0]);
  EXPECT_EQ(boundary_triangles(m), std::vector<Triangle>(faces.begin(), faces.end()));
}

TEST(BoundaryTriangles, OutwardClosedAndDeterministic) {
  const TetMesh m = two_cubes();
  const std::vector<Triangle> tris = boundary_triangles(m);
  ASSERT_EQ(tris.size(), 20u);  // a 2×1×1 box: 10 squares
  Vec3 centre;
  for (const Vec3& p : m.vertices) centre += p / double(m.vertices.size());
  double enclosed = 0;
  for (const Triangle& t : tris) {
    const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    EXPECT_GT(dot(cross(b - a, c - a), (a + b + c) / 3.0 - centre), 0);  // convex box: outward
    enclosed += dot(a, cross(b, c)) / 6.0;
  }
  EXPECT_NEAR(enclosed, total_volume(m), 1e-12);
  EXPECT_EQ(boundary_triangles(m), tris);
}

TEST(FaceNeighbours, PairsSharedFacesAndLinksAFaceOfThreeTetsInACycle) {
  // Tets 0 and 1 share face {1,2,3}; tets 2, 3 and 4 all share face {5,6,7} (invalid mesh).
  const std::vector<Tet> tets = {{0, 1, 2, 3}, {4, 1, 3, 2}, {5, 6, 7, 8}, {9, 5, 7, 6}, {10, 5, 6, 7}};
  const std::vector<std::int64_t> n = face_neighbours(11, tets);
  ASSERT_EQ(n.size(), 20u);
  const auto corners = [&](std::int64_t f) {
    Triangle t = outward_faces(tets[f / 4])[f % 4];
    std::sort(t.begin(), t.end());
    return t;
  };
  int shared = 0;
  for (std::int64_t f = 0; f < 20; ++f) {
    if (n[f] < 0) continue;
    ++shared;
    EXPECT_NE(n[f] / 4, f / 4);
    EXPECT_EQ(corners(n[f]), corners(f));
  }
  EXPECT_EQ(shared, 5);            // 2 faces of the pair, 3 of the triple
  EXPECT_EQ(n[0], 4);              // face {1,2,3}: tet 0 face 0 and tet 1 face 0
  EXPECT_EQ(n[4], 0);
  EXPECT_EQ(n[n[n[11]]], 11);      // a triple is a 3-cycle (face {5,6,7} of tet 2)
  EXPECT_THROW(face_neighbours(4, {{0, 1, 2, 4}}), std::invalid_argument);
}

TEST(BoundaryTriangles, AMillionTetsGiveTheBoxSurface) {
  const TetMesh m = kuhn_block(60, 60, 50, 0.5, Vec3{}, 30);
  ASSERT_GT(m.tets.size(), 1'000'000u);
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Triangle> tris = boundary_triangles(m);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("boundary_triangles: %zu tets -> %zu triangles in %.3f s\n", m.tets.size(),
              tris.size(), seconds);
  EXPECT_EQ(tris.size(), std::size_t(4 * (60 * 60 + 60 * 50 + 60 * 50)));
  // Its speed belongs to bench/, not to an assertion here.
}

TEST_F(MeshIo, EveryFormatIsReadByMeshio) {
  const TetMesh m = two_cubes();
  const double volume = total_volume(m);
  const std::string bounds = bounds_option(m);
  for (const std::string ext : {".mesh", ".vtu", ".msh", ".inp", ".feb", ".node"}) {
    SCOPED_TRACE(ext);
    const std::string path = file("cubes" + ext);
    write_mesh(m, path);
    const std::string triangles =
        ext == ".mesh" || ext == ".msh" || ext == ".feb" ? " --triangles 20" : "";
    EXPECT_EQ(check_with_meshio(path, 12, 12, volume, bounds + triangles), 0);
  }
  EXPECT_TRUE(fs::exists(file("cubes.ele")));
  EXPECT_EQ(check_with_meshio(file("cubes.ele"), 12, 12, volume), 0);
  for (const std::string ext : {".stl", ".ply", ".obj"}) {
    SCOPED_TRACE(ext);
    write_mesh(m, file("surface" + ext));
    EXPECT_EQ(check_with_meshio(file("surface" + ext), 12, 20, volume, ext == ".stl" ? "" : bounds),
              0);
  }
  MeshWriteOptions ascii;
  ascii.vtu_ascii = true;
  write_mesh(m, file("ascii.vtu"), ascii);
  EXPECT_EQ(check_with_meshio(file("ascii.vtu"), 12, 12, volume, bounds), 0);
  // Upper-case extensions work too.
  write_mesh(m, file("UPPER.MESH"));
  EXPECT_TRUE(fs::exists(file("UPPER.MESH")));
}

TEST_F(MeshIo, GmshLoadsTheMshFile) {
  if (run("command -v gmsh > /dev/null") != 0) GTEST_SKIP() << "gmsh not installed";
  const TetMesh m = two_cubes();
  write_mesh(m, file("cubes.msh"));
  const std::string log = file("gmsh.log");
  ASSERT_EQ(run("gmsh '" + file("cubes.msh") + "' -0 -o '" + file("resaved.msh") + "' > '" + log +
                "' 2>&1"),
            0);
  EXPECT_EQ(slurp(log).find("Error"), std::string::npos) << slurp(log);
  ASSERT_EQ(run("gmsh -check '" + file("cubes.msh") + "' > '" + log + "' 2>&1"), 0);
  EXPECT_EQ(slurp(log).find("Error"), std::string::npos) << slurp(log);
  EXPECT_EQ(slurp(log).find("Warning"), std::string::npos) << slurp(log);
  // What gmsh wrote back still has the same tets, triangles and volume.
  EXPECT_EQ(check_with_meshio(file("resaved.msh"), 12, 12, total_volume(m), " --triangles 20"), 0);
}

TEST_F(MeshIo, OwnFormatsRoundTripExactly) {
  TetMesh m = two_cubes();
  MeshWriteOptions ascii;
  ascii.vtu_ascii = true;
  for (const auto& [name, options] :
       {std::pair{"a.mesh", MeshWriteOptions{}}, std::pair{"b.vtu", MeshWriteOptions{}},
        std::pair{"c.vtu", ascii}}) {
    SCOPED_TRACE(name);
    write_mesh(m, file(name), options);
    expect_same(read_mesh(file(name)), m);
  }
  // All-1 labels read back as "no labels" (which means all 1).
  m.labels.clear();
  write_mesh(m, file("unlabelled.vtu"));
  expect_same(read_mesh(file("unlabelled.vtu")), m);
}

TEST_F(MeshIo, ReadsWhatMeshioWrites) {
  const TetMesh m = two_cubes();
  write_mesh(m, file("ours.mesh"));
  for (const std::string mode : {"binary", "zlib", "ascii"}) {
    SCOPED_TRACE(mode);
    const std::string out = file("meshio_" + mode + ".vtu");
    ASSERT_EQ(run("/usr/bin/python3 '" + kChecker + "' --convert '" + file("ours.mesh") + "' '" +
                  out + "' " + mode),
              0);
    const TetMesh r = read_mesh(out);  // meshio adds the boundary triangles as cells: ignored
    EXPECT_EQ(r.tets, m.tets);
    EXPECT_EQ(r.labels, m.labels);  // from the medit:ref cell array
    ASSERT_EQ(r.vertices.size(), m.vertices.size());
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      const double tolerance = mode == "ascii" ? 1e-10 : 0.0;  // meshio's ASCII keeps 12 digits
      EXPECT_LE(distance(r.vertices[i], m.vertices[i]), tolerance);
    }
  }
  ASSERT_EQ(run("/usr/bin/python3 '" + kChecker + "' --convert '" + file("ours.mesh") + "' '" +
                file("meshio.mesh") + "'"),
            0);
  expect_same(read_mesh(file("meshio.mesh")), m);
}

TEST_F(MeshIo, WriteOptionsCellDataGoesToVtu) {
  const TetMesh m = two_cubes();
  MeshWriteOptions options;
  std::vector<double> quality(m.tets.size());
  for (std::size_t t = 0; t < quality.size(); ++t) quality[t] = 0.5 + 0.01 * double(t);
  options.cell_data = {{"quality_radius_ratio", quality}};
  write_mesh(m, file("q.vtu"), options);
  const std::string text = slurp(file("q.vtu"));
  EXPECT_NE(text.find("Name=\"quality_radius_ratio\""), std::string::npos);
  EXPECT_EQ(check_with_meshio(file("q.vtu"), 12, 12, total_volume(m)), 0);
  options.cell_data[0].second.pop_back();  // wrong size: refused before any file is made
  EXPECT_THROW(write_mesh(m, file("bad.vtu"), options), InputError);
  EXPECT_FALSE(fs::exists(file("bad.vtu")));
}

TEST_F(MeshIo, ReadsMeditFromOtherTools) {
  // As CGAL and others write it: comments, "Dimension" on its own line, sections we skip,
  // version 1, and a tet in the opposite orientation (reoriented on reading).
  spit(dir_ / "cgal.mesh",
       "MeshVersionFormatted 1\n# written by some tool\nDimension\n3\nVertices\n5\n"
       "0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 2\nCorners\n2\n1\n2\nRequiredVertices\n1\n3\n"
       "Edges\n1\n1 2 5\nTriangles\n2\n1 2 3 4\n2 3 5 4\nTetrahedra\n2\n1 2 4 3 9 # inverted\n"
       "2 3 4 5 4\nRidges\n1\n1\nNormals\n1\n0.5 +0.5 -1e-3\nEnd\n");
  const TetMesh m = read_mesh(file("cgal.mesh"));
  ASSERT_EQ(m.vertices.size(), 5u);
  EXPECT_EQ(m.vertices[4], (Vec3{1, 1, 1}));
  ASSERT_EQ(m.tets.size(), 2u);
  EXPECT_EQ(m.tets[0], (Tet{0, 1, 2, 3}));
  EXPECT_GT(signed_volume(m, m.tets[1]), 0);
  EXPECT_EQ(m.labels, (std::vector<std::int32_t>{9, 4}));
}

namespace {

template <typename T>
std::string bytes_of(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

std::string base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = 0;
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    for (std::size_t k = 0; k < 3; ++k) v = v << 8 | (k < n ? (unsigned char)bytes[i + k] : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kAlphabet[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

// A VTK-style file with appended data (raw or base64, header encoded separately from the
// data as VTK does; optionally zlib-compressed in several blocks), UInt32 headers, Float32 points,
// Int64 cells, a triangle cell to be ignored and MaterialIds as labels.
std::string vtk_style_vtu(const TetMesh& m, bool raw, bool zlib) {
  std::vector<float> points;
  for (const Vec3& p : m.vertices)
    points.insert(points.end(), {float(p.x), float(p.y), float(p.z)});
  std::vector<std::int64_t> connectivity = {0, 1, 2}, offsets = {3};
  std::vector<std::uint8_t> types = {5};
  std::vector<std::int32_t> ids = {77};
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    connectivity.insert(connectivity.end(), m.tets[t].begin(), m.tets[t].end());
    offsets.push_back(offsets.back() + 4);
    types.push_back(10);
    ids.push_back(m.labels[t]);
  }
  std::string appended, arrays;
  const auto add = [&](const std::string& attributes, const std::string& data) {
    arrays += "<DataArray " + attributes + " format=\"appended\" offset=\"" +
              std::to_string(appended.size()) + "\"/>\n";
    std::vector<std::uint32_t> header = {std::uint32_t(data.size())};
    std::string body = data;
    if (zlib) {  // blocks of 64 bytes, so arrays span several
      const std::size_t block = 64, blocks = (data.size() + block - 1) / block;
      header = {std::uint32_t(blocks), std::uint32_t(block), std::uint32_t(data.size() % block)};
      body.clear();
      for (std::size_t b = 0; b < blocks; ++b) {
        const std::string chunk = data.substr(b * block, block);
        std::string packed(compressBound(chunk.size()), '\0');
        uLongf size = packed.size();
        compress(reinterpret_cast<Bytef*>(packed.data()), &size,
                 reinterpret_cast<const Bytef*>(chunk.data()), chunk.size());
        header.push_back(std::uint32_t(size));
        body += packed.substr(0, size);
      }
    }
    appended += raw ? bytes_of(header) + body : base64(bytes_of(header)) + base64(body);
  };
  add("type=\"Float32\" Name=\"Points\" NumberOfComponents=\"3\"", bytes_of(points));
  const std::string points_xml = arrays;
  arrays.clear();
  add("type=\"Int64\" Name=\"connectivity\"", bytes_of(connectivity));
  add("type=\"Int64\" Name=\"offsets\"", bytes_of(offsets));
  add("type=\"UInt8\" Name=\"types\"", bytes_of(types));
  const std::string cells_xml = arrays;
  arrays.clear();
  add("type=\"Int32\" Name=\"MaterialIds\"", bytes_of(ids));
  std::string xml = "<?xml version=\"1.0\"?>\n<!-- from a VTK-like writer -->\n";
  xml += "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\"";
  xml += zlib ? " compressor=\"vtkZLibDataCompressor\">\n" : ">\n";
  xml += "<UnstructuredGrid>\n<Piece NumberOfPoints=\"" + std::to_string(m.vertices.size()) +
         "\" NumberOfCells=\"" + std::to_string(m.tets.size() + 1) + "\">\n";
  xml +=
      "<PointData>\n</PointData>\n<CellData Scalars=\"MaterialIds\">\n" + arrays + "</CellData>\n";
  xml += "<Points>\n" + points_xml + "</Points>\n<Cells>\n" + cells_xml + "</Cells>\n";
  xml += "</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"";
  xml += raw ? "raw" : "base64";
  return xml + "\">\n   _" + appended + "\n</AppendedData>\n</VTKFile>\n";
}

}  // namespace

TEST_F(MeshIo, ReadsVtkStyleAppendedData) {
  TetMesh m = kuhn_block(2, 2, 1, 0.25, Vec3{1, 2, 3}, 1);  // exact in Float32
  for (const auto& [raw, zlib] :
       {std::pair{true, false}, {false, false}, {true, true}, {false, true}}) {
    const std::string name = std::string(raw ? "raw" : "base64") + (zlib ? "_zlib" : "");
    SCOPED_TRACE(name);
    const std::string path = file(name + ".vtu");
    spit(path, vtk_style_vtu(m, raw, zlib));
    expect_same(read_mesh(path), m);
    EXPECT_EQ(check_with_meshio(path, m.vertices.size(), m.tets.size(), total_volume(m)), 0);
  }
}

TEST_F(MeshIo, BadFilesGiveOneLineNamingThePath) {
  const std::string medit_head =
      "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n";
  const std::string vtu_head =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" "
      "version=\"1.0\">\n<UnstructuredGrid>\n";
  const auto vtu_piece = [&](const std::string& points, const std::string& attributes,
                             const std::string& connectivity) {
    return vtu_head + "<Piece " + attributes +
           ">\n<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">" +
           points +
           "</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int32\" Name=\"connectivity\" "
           "format=\"ascii\">" +
           connectivity +
           "</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" "
           "format=\"ascii\">4</DataArray>\n"
           "<DataArray type=\"UInt8\" Name=\"types\" "
           "format=\"ascii\">10</DataArray>\n</Cells>\n</Piece>\n"
           "</UnstructuredGrid>\n</VTKFile>\n";
  };
  const std::string good_points = "0 0 0 1 0 0 0 1 0 0 0 1";
  const std::string one_tet = "NumberOfPoints=\"4\" NumberOfCells=\"1\"";
  // Sanity: the well-formed versions of the files below read.
  spit(dir_ / "ok.mesh", medit_head + "0 0 1 0\nTetrahedra\n1\n1 2 3 4 1\nEnd\n");
  EXPECT_EQ(read_error(file("ok.mesh")), "");
  spit(dir_ / "ok.vtu", vtu_piece(good_points, one_tet, "0 1 2 3"));
  EXPECT_EQ(read_error(file("ok.vtu")), "");

  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "no such file"},  // the file is not created
      {"", "not a file"},    // a folder
      {"", "not a Medit"},
      {"\x7f\x45\x4c\x46\x02\x01\x01\0\0\0garbage\xff\xfe", "not a Medit"},
      {"MeshVersionFormatted 2\nDimension 3\nVertices\n999999999999\n0 0 0 0\n", "does not fit"},
      {medit_head + "0 0 1 0\nTetrahedra\n2\n1 2 3 4 1\n1 2", "file ends inside Tetrahedra"},
      {medit_head + "0 0 1 0\nTetrahedra\n1\n1 2 3 5 1\nEnd\n", "refers to vertex 5"},
      {medit_head + "0 0 1 0\nTetrahedra\n1\n0 2 3 4 1\nEnd\n", "vertex index 0 out of range"},
      {medit_head + "0 nan 1 0\nTetrahedra\n1\n1 2 3 4 1\nEnd\n", "non-finite"},
      {medit_head + "0 0 1x 0\nTetrahedra\n1\n1 2 3 4 1\nEnd\n", "bad coordinate '1x'"},
      {medit_head + "0 0 1 0\nEnd\n", "no tetrahedra"},
      {"MeshVersionFormatted 2\nDimension 2\n", "only 3D"},
      {"", "not a VTK XML file"},
      {"PK\x03\x04 binary junk < > \" ", "not a VTK XML file"},
      {"<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=",
       "malformed XML"},
      {"<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\"></VTKFile>", "not an UnstructuredGrid"},
      {vtu_piece(good_points, "NumberOfPoints=\"999999999\" NumberOfCells=\"1\"", "0 1 2 3"),
       "values, expected"},
      {vtu_piece(good_points, "NumberOfPoints=\"99999999999\" NumberOfCells=\"1\"", "0 1 2 3"),
       "not a count"},
      {vtu_piece(good_points, "NumberOfPoints=\"4\" NumberOfCells=\"-1\"", "0 1 2 3"),
       "not a count"},
      {vtu_piece(good_points, one_tet, "0 1 2 4"), "out of range"},
      {vtu_piece("0 0 0 1 0 0 0 1 0 0 0 inf", one_tet, "0 1 2 3"), "non-finite"},
      {vtu_piece(good_points, one_tet, "0 1 2 3 4"), "more values"},
      {vtu_piece(good_points, one_tet, "0 1 two 3"), "bad number 'two'"},
      {vtu_head + "<Piece NumberOfPoints=\"1\" NumberOfCells=\"0\">\n<Points>\n<DataArray "
                  "type=\"Float64\" "
                  "NumberOfComponents=\"3\" format=\"binary\">AAAA*AAA</DataArray>",
       "invalid base64"},
      {"<VTKFile type=\"UnstructuredGrid\" "
       "compressor=\"vtkLZ4DataCompressor\"><UnstructuredGrid><Piece "
       "NumberOfPoints=\"0\" NumberOfCells=\"0\"/></UnstructuredGrid></VTKFile>",
       "unsupported compressor"},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto& [content, expected] = cases[i];
    const bool vtu = expected.find("VTK") != std::string::npos ||
                     content.find("VTKFile") != std::string::npos || content.starts_with("PK");
    const std::string path = file("bad" + std::to_string(i) + (vtu ? ".vtu" : ".mesh"));
    if (expected == "not a file") fs::create_directory(path);
    if (expected != "no such file" && expected != "not a file") spit(path, content);
    const std::string error = read_error(path);
    SCOPED_TRACE(path);
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find(expected), std::string::npos) << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  }
  const std::string error = read_error(file("model.stl"));
  EXPECT_NE(error.find("supported: .mesh .vtu"), std::string::npos) << error;
}

// Every prefix of a file and single-byte corruptions must give a mesh or an InputError.
TEST_F(MeshIo, TruncatedAndCorruptedFilesNeverCrash) {
  const TetMesh m = two_cubes();
  write_mesh(m, file("a.mesh"));
  write_mesh(m, file("b.vtu"));
  MeshWriteOptions ascii;
  ascii.vtu_ascii = true;
  write_mesh(m, file("c.vtu"), ascii);
  spit(dir_ / "d.vtu", vtk_style_vtu(m, true, true));
  spit(dir_ / "e.vtu", vtk_style_vtu(m, true, false));
  int errors = 0, reads = 0;
  for (const std::string name : {"a.mesh", "b.vtu", "c.vtu", "d.vtu", "e.vtu"}) {
    const std::string original = slurp(dir_ / name);
    const std::string path = file("fuzz" + fs::path(name).extension().string());
    for (std::size_t cut = 0; cut < original.size(); cut += 1 + cut / 16) {
      std::string variants[2] = {original.substr(0, cut), original};
      variants[1][cut] = char(variants[1][cut] ^ (cut % 2 ? 0x5a : 0x01));
      for (const std::string& variant : variants) {
        spit(path, variant);
        try {
          const TetMesh r = read_mesh(path);
          for (const Tet& t : r.tets)
            for (std::int32_t v : t) ASSERT_LT(std::size_t(v), r.vertices.size());
          ++reads;
        } catch (const InputError&) {
          ++errors;
        }
      }
    }
  }
  std::printf("corrupted files: %d read, %d refused\n", reads, errors);
  EXPECT_GT(errors, 100);
}

TEST_F(MeshIo, FailedWritesLeaveNoFile) {
  const TetMesh m = two_cubes();
  const auto write_error = [&](const TetMesh& mesh, const std::string& path) -> std::string {
    try {
      write_mesh(mesh, path);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  const auto no_temp_files = [](const fs::path& dir) {
    for (const auto& entry : fs::directory_iterator(dir))
      if (entry.path().filename().string().find(".tmp") != std::string::npos) return false;
    return true;
  };
  // A missing folder.
  const std::string missing = file("no/such/folder/mesh.vtu");
  std::string error = write_error(m, missing);
  EXPECT_NE(error.find("cannot write " + missing + ": "), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos);
  // An unknown extension lists the supported ones.
  error = write_error(m, file("mesh.xyz"));
  EXPECT_NE(error.find(".mesh .vtu .msh .inp .feb .node .ele .stl .ply .obj"), std::string::npos)
      << error;
  EXPECT_FALSE(fs::exists(file("mesh.xyz")));
  // An invalid mesh is refused, and the file already there is kept as it was.
  spit(dir_ / "keep.mesh", "old content");
  TetMesh broken = m;
  broken.tets[3][1] = 99;
  error = write_error(broken, file("keep.mesh"));
  EXPECT_NE(error.find("refers to vertex 99"), std::string::npos) << error;
  EXPECT_EQ(slurp(dir_ / "keep.mesh"), "old content");
  broken = m;
  broken.vertices[5].y = std::nan("");
  EXPECT_NE(write_error(broken, file("nan.vtu")).find("non-finite"), std::string::npos);
  EXPECT_FALSE(fs::exists(file("nan.vtu")));
  EXPECT_TRUE(no_temp_files(dir_));
  // A read-only folder. Root ignores permissions, so there the case cannot be tested.
  const fs::path readonly = dir_ / "readonly";
  fs::create_directory(readonly);
  fs::permissions(readonly, fs::perms::owner_read | fs::perms::owner_exec);
  if (std::FILE* probe = std::fopen((readonly / "probe").c_str(), "w")) {
    std::fclose(probe);
    fs::remove(readonly / "probe");
    std::printf(
        "[ SKIPPED  ] read-only folder case: running as root, permissions do not stop writes\n");
  } else {
    for (const std::string ext : {".mesh", ".vtu", ".node", ".stl"}) {
      error = write_error(m, (readonly / ("m" + ext)).string());
      EXPECT_NE(error.find("cannot write " + (readonly / ("m" + ext)).string() + ": "),
                std::string::npos)
          << error;
    }
    EXPECT_TRUE(fs::is_empty(readonly));
  }
}

TEST_F(MeshIo, WritesAreDeterministic) {
  const TetMesh m = two_cubes();
  MeshWriteOptions options;
  options.cell_data = {{"quality", std::vector<double>(m.tets.size(), 0.75)}};
  for (const std::string ext : mesh_write_extensions()) {
    SCOPED_TRACE(ext);
    write_mesh(m, file("first" + ext), options);
    write_mesh(m, file("second" + ext), options);
    EXPECT_EQ(slurp(file("first" + ext)), slurp(file("second" + ext)));
  }
  EXPECT_EQ(slurp(file("first.ele")), slurp(file("second.ele")));
}

TEST_F(MeshIo, ReadsBigEndianAndInformationKeys) {
  // Inline base64, big endian with UInt64 headers; the points carry a VTK 9 InformationKey
  // child before their (ASCII) values.
  const auto big_endian = [](auto value) {
    std::string bytes(reinterpret_cast<const char*>(&value), sizeof value);
    return std::string(bytes.rbegin(), bytes.rend());
  };
  const auto block = [&](const std::string& data) {
    return base64(big_endian(std::uint64_t(data.size())) + data);
  };
  std::string connectivity, offsets, labels;
  for (std::int32_t v : {0, 1, 2, 3}) connectivity += big_endian(v);
  offsets = big_endian(std::int64_t{4});
  labels = big_endian(double{5.0});  // integer labels stored as floats
  const std::string xml =
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"BigEndian\" "
      "header_type=\"UInt64\">\n"
      "<UnstructuredGrid><Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n"
      "<Points><DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" "
      "format=\"ascii\">\n"
      "<InformationKey name=\"L2_NORM_RANGE\" location=\"vtkDataArray\" length=\"2\">\n"
      "<Value index=\"0\">0</Value><Value index=\"1\">1</Value></InformationKey>\n"
      "0 0 0  1 0 0  0 1 0  0 0 1.5\n</DataArray></Points>\n<Cells>\n"
      "<DataArray type=\"Int32\" Name=\"connectivity\" format=\"binary\">" +
      block(connectivity) +
      "</DataArray>\n"
      "<DataArray type=\"Int64\" Name=\"offsets\" format=\"binary\">" +
      block(offsets) +
      "</DataArray>\n"
      "<DataArray type=\"UInt8\" Name=\"types\" format=\"binary\">" +
      block("\x0a") +
      "</DataArray>\n</Cells>\n"
      "<CellData><DataArray type=\"Float64\" Name=\"subdomain\" format=\"binary\">" +
      block(labels) + "</DataArray></CellData>\n</Piece></UnstructuredGrid></VTKFile>\n";
  spit(dir_ / "be.vtu", xml);
  const TetMesh m = read_mesh(file("be.vtu"));
  ASSERT_EQ(m.vertices.size(), 4u);
  EXPECT_EQ(m.vertices[3], (Vec3{0, 0, 1.5}));
  EXPECT_EQ(m.tets, (std::vector<Tet>{{0, 1, 2, 3}}));
  EXPECT_EQ(m.labels, (std::vector<std::int32_t>{5}));
}

TEST_F(MeshIo, NonPositiveLabelsAndUnusedVertices) {
  TetMesh m = two_cubes();
  for (std::int32_t& label : m.labels) label = label == 1 ? -3 : 0;
  m.vertices.push_back({5, 5, 5});  // used by no tet: kept in volume files, not in surfaces
  const double volume = total_volume(m);
  for (const std::string ext : {".mesh", ".vtu", ".msh", ".inp", ".feb", ".node"}) {
    SCOPED_TRACE(ext);
    write_mesh(m, file("m" + ext));
    EXPECT_EQ(check_with_meshio(file("m" + ext), 13, 12, volume), 0);
  }
  EXPECT_NE(slurp(file("m.inp")).find("ELSET=SUBDOMAIN_M3"), std::string::npos);
  EXPECT_NE(slurp(file("m.msh")).find("3 1 \"label_-3\""), std::string::npos);  // physical tag 1
  expect_same(read_mesh(file("m.mesh")), m);
  expect_same(read_mesh(file("m.vtu")), m);
  for (const std::string ext : {".ply", ".obj"}) {
    write_mesh(m, file("s" + ext));
    EXPECT_EQ(check_with_meshio(file("s" + ext), 12, 20, volume), 0);
  }
  if (run("command -v gmsh > /dev/null") == 0) {
    EXPECT_EQ(run("gmsh -check '" + file("m.msh") + "' > /dev/null 2>&1"), 0);
  }
}
