// Format dispatch, the atomic buffered output shared by all writers, the Medit reader and the
// checks every read mesh goes through. Readers distrust the file: counts are checked against
// the bytes present before anything is allocated, so a truncated or hostile file gives an
// InputError, never a crash or a huge allocation.
#include "io/mesh_io.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>

#include "base/errors.h"

namespace cvt {
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kBufferSize = 1 << 20;

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string joined(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& item : items) s += (s.empty() ? "" : " ") + item;
  return s;
}

// Refuses meshes a writer would turn into an invalid file, before any file is created.
void check_writable(const TetMesh& mesh, const std::string& path, const MeshWriteOptions& options) {
  const auto fail = [&](const std::string& why) {
    throw InputError("cannot write " + path + ": " + why);
  };
  if (mesh.tets.empty()) fail("the mesh has no tetrahedra");
  if (mesh.vertices.size() > std::size_t(INT32_MAX)) fail("too many vertices");
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& p = mesh.vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      fail("vertex " + std::to_string(i) + " has a non-finite coordinate");
    }
  }
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    for (std::int32_t v : mesh.tets[t]) {
      if (v < 0 || std::size_t(v) >= mesh.vertices.size()) {
        fail("tet " + std::to_string(t) + " refers to vertex " + std::to_string(v) + " of " +
             std::to_string(mesh.vertices.size()));
      }
    }
  }
  if (!mesh.labels.empty() && mesh.labels.size() != mesh.tets.size()) {
    fail("labels has " + std::to_string(mesh.labels.size()) + " values for " +
         std::to_string(mesh.tets.size()) + " tets");
  }
  for (const auto& [name, values] : options.cell_data) {
    if (values.size() != mesh.tets.size()) {
      fail("cell data '" + name + "' has " + std::to_string(values.size()) + " values for " +
           std::to_string(mesh.tets.size()) + " tets");
    }
  }
}

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("cannot read " + path + ": no such file");
  if (!fs::is_regular_file(path, ec)) throw InputError("cannot read " + path + ": not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot read " + path + ": " + std::strerror(errno));
  const auto size = fs::file_size(path, ec);
  if (ec) throw InputError("cannot read " + path + ": " + ec.message());
  std::string text(size, '\0');
  in.read(text.data(), std::streamsize(size));
  if (std::size_t(in.gcount()) != size) throw InputError("cannot read " + path + ": read failed");
  return text;
}

// The whole token as a number (from_chars, so locale-independent); a leading '+' is accepted.
template <typename T>
std::optional<T> parse_whole(std::string_view token) {
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  T value{};
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

// Whitespace-separated tokens with '#' comments, tracking the line for messages.
class MeditTokens {
 public:
  explicit MeditTokens(std::string_view text) : text_(text) {}
  std::string_view next() {
    skip();
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return text_.substr(start, pos_ - start);
  }
  bool next_is_number() {
    skip();
    if (pos_ >= text_.size()) return false;
    const char c = text_[pos_];
    return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.';
  }
  std::size_t line() const { return line_; }
  std::size_t remaining() const { return text_.size() - pos_; }

 private:
  void skip() {
    while (pos_ < text_.size()) {
      if (text_[pos_] == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else if (is_space(text_[pos_])) {
        line_ += text_[pos_++] == '\n';
      } else {
        break;
      }
    }
  }
  std::string_view text_;
  std::size_t pos_ = 0, line_ = 1;
};

}  // namespace

const std::vector<std::string>& mesh_write_extensions() {
  static const std::vector<std::string> extensions = {".mesh", ".vtu", ".msh", ".inp", ".feb",
                                                      ".node", ".ele", ".stl", ".ply", ".obj"};
  return extensions;
}

bool mesh_format_has_cell_data(const std::string& path) { return lower_extension(path) == ".vtu"; }

const std::vector<std::string>& mesh_read_extensions() {
  static const std::vector<std::string> extensions = {".mesh", ".vtu"};
  return extensions;
}

void write_mesh(const TetMesh& mesh, const std::string& path, const MeshWriteOptions& options) {
  const std::string ext = lower_extension(path);
  const auto& known = mesh_write_extensions();
  if (std::find(known.begin(), known.end(), ext) == known.end()) {
    throw InputError("cannot write " + path + ": unknown mesh extension '" + ext +
                     "' (supported: " + joined(known) + ")");
  }
  check_writable(mesh, path, options);
  if (ext == ".node" || ext == ".ele") {
    // TetGen needs both files; both are complete before either replaces an old one.
    const fs::path stem = fs::path(path).replace_extension();
    detail::AtomicOutput node(stem.string() + ".node"), ele(stem.string() + ".ele");
    detail::write_tetgen(mesh, node, ele);
    node.finish();
    ele.finish();
    node.commit();
    ele.commit();
    return;
  }
  detail::AtomicOutput out(path);
  if (ext == ".mesh") detail::write_medit(mesh, out);
  if (ext == ".vtu") detail::write_vtu(mesh, options, out);
  if (ext == ".msh") detail::write_gmsh(mesh, out);
  if (ext == ".inp") detail::write_abaqus(mesh, out);
  if (ext == ".feb") detail::write_febio(mesh, out);
  if (ext == ".stl") detail::write_stl(mesh, out);
  if (ext == ".ply") detail::write_ply(mesh, out);
  if (ext == ".obj") detail::write_obj(mesh, out);
  out.commit();
}

TetMesh read_mesh(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".mesh" && ext != ".vtu") {
    throw InputError("cannot read " + path + ": unknown mesh extension '" + ext +
                     "' (supported: " + joined(mesh_read_extensions()) + ")");
  }
  const std::string text = read_whole_file(path);
  TetMesh mesh = ext == ".mesh" ? detail::read_medit(path, text) : detail::read_vtu(path, text);
  detail::finish_read_mesh(path, mesh);
  return mesh;
}

namespace detail {

std::optional<double> parse_double(std::string_view token) {
  return parse_whole<double>(token);
}
std::optional<std::int64_t> parse_int(std::string_view token) {
  return parse_whole<std::int64_t>(token);
}

TetMesh read_medit(const std::string& path, std::string_view text) {
  MeditTokens tokens(text);
  const auto fail = [&](const std::string& why) {
    throw InputError(path + ": line " + std::to_string(tokens.line()) + ": " + why);
  };
  const auto integer = [&](const char* what) {
    const std::string_view token = tokens.next();
    if (token.empty()) fail(std::string("file ends inside ") + what);
    const auto value = parse_int(token);
    if (!value)
      fail(std::string("bad integer '") + std::string(token.substr(0, 40)) + "' in " + what);
    return *value;
  };
  // A count of records of `fields` numbers each; every number takes at least 2 bytes.
  const auto count = [&](const char* what, std::int64_t fields) {
    const std::int64_t n = integer(what);
    if (n < 0 || n > std::int64_t(tokens.remaining() / (2 * fields) + 1)) {
      fail(std::string(what) + " count " + std::to_string(n) + " does not fit in the file");
    }
    return n;
  };
  const auto vertex_index = [&](const char* what) {
    const std::int64_t v = integer(what);
    if (v < 1 || v > INT32_MAX)
      fail(std::string("vertex index ") + std::to_string(v) + " out of range in " + what);
    return std::int32_t(v - 1);
  };

  TetMesh mesh;
  std::string_view keyword = tokens.next();
  if (keyword != "MeshVersionFormatted") {
    throw InputError(path + ": not a Medit ASCII mesh (no MeshVersionFormatted at the start)");
  }
  bool have_vertices = false;
  for (; !keyword.empty() && keyword != "End"; keyword = tokens.next()) {
    if (keyword == "MeshVersionFormatted") {
      integer("MeshVersionFormatted");
    } else if (keyword == "Dimension") {
      const std::int64_t dim = integer("Dimension");
      if (dim != 3) fail("only 3D meshes are supported (Dimension " + std::to_string(dim) + ")");
    } else if (keyword == "Vertices") {
      const std::int64_t n = count("Vertices", 4);
      mesh.vertices.resize(std::size_t(n));
      for (Vec3& p : mesh.vertices) {
        for (int a = 0; a < 3; ++a) {
          const std::string_view token = tokens.next();
          const auto value = parse_double(token);
          if (!value) fail("bad coordinate '" + std::string(token.substr(0, 40)) + "' in Vertices");
          p[a] = *value;
        }
        tokens.next();  // the vertex ref, meaningless here
      }
      have_vertices = true;
    } else if (keyword == "Tetrahedra") {
      const std::int64_t n = count("Tetrahedra", 5);
      mesh.tets.resize(std::size_t(n));
      mesh.labels.resize(std::size_t(n));
      for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
        for (std::int32_t& v : mesh.tets[t]) v = vertex_index("Tetrahedra");
        const std::int64_t ref = integer("Tetrahedra");
        if (ref < INT32_MIN || ref > INT32_MAX) fail("tetrahedron ref out of range");
        mesh.labels[t] = std::int32_t(ref);
      }
    } else if (std::string_view("0123456789+-.").find(keyword[0]) != std::string_view::npos) {
      fail("expected a keyword, found '" + std::string(keyword.substr(0, 40)) + "'");
    } else {
      // Unknown or unneeded section (Triangles, Edges, Corners, Ridges, Normals, ...): skip
      // its numbers up to the next keyword.
      while (tokens.next_is_number()) tokens.next();
    }
  }
  if (!have_vertices) throw InputError(path + ": no Vertices section");
  return mesh;
}

void finish_read_mesh(const std::string& path, TetMesh& mesh) {
  const auto fail = [&](const std::string& why) { throw InputError(path + ": " + why); };
  if (mesh.tets.empty()) fail("no tetrahedra");
  if (mesh.vertices.size() > std::size_t(INT32_MAX)) fail("too many vertices");
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& p = mesh.vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      fail("vertex " + std::to_string(i + 1) + " has a non-finite coordinate");
    }
  }
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    Tet& tet = mesh.tets[t];
    for (std::int32_t v : tet) {
      if (v < 0 || std::size_t(v) >= mesh.vertices.size()) {
        fail("tetrahedron " + std::to_string(t + 1) + " refers to vertex " +
             std::to_string(std::int64_t(v) + 1) + " but there are " +
             std::to_string(mesh.vertices.size()) + " vertices");
      }
    }
    // Some tools write the opposite orientation; TetMesh promises positive tets.
    if (signed_volume(mesh, tet) < 0) std::swap(tet[2], tet[3]);
  }
  if (std::all_of(mesh.labels.begin(), mesh.labels.end(), [](std::int32_t l) { return l == 1; })) {
    mesh.labels.clear();
  }
}

AtomicOutput::AtomicOutput(std::string path) : path_(std::move(path)), buffer_(kBufferSize) {
  const fs::path target(path_);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError("cannot write " + path_ + ": folder does not exist");
  }
  // A hidden name beside the target, so the rename stays on one file system.
  std::string temp_name = target.filename().string();
  temp_name.insert(0, 1, '.');
  // pid and object address keep concurrent writers of the same target apart.
  temp_name += ".tmp" + std::to_string(getpid()) + "_" + std::to_string(std::uintptr_t(this));
  temp_path_ = (dir / temp_name).string();
  file_ = std::fopen(temp_path_.c_str(), "wb");
  if (!file_) throw InputError("cannot write " + path_ + ": " + std::strerror(errno));
}

AtomicOutput::~AtomicOutput() {
  if (file_) std::fclose(file_);
  if (!committed_) std::remove(temp_path_.c_str());
}

void AtomicOutput::fail(const std::string& reason) {
  if (file_) std::fclose(file_);
  file_ = nullptr;
  std::remove(temp_path_.c_str());
  committed_ = true;  // nothing left to clean up
  throw InputError("cannot write " + path_ + ": " + reason);
}

void AtomicOutput::flush() {
  if (used_ == 0) return;
  if (!file_) fail("write after finish");
  if (std::fwrite(buffer_.data(), 1, used_, file_) != used_) fail(std::strerror(errno));
  used_ = 0;
}

AtomicOutput& AtomicOutput::operator<<(std::string_view text) {
  bytes(text.data(), text.size());
  return *this;
}

AtomicOutput& AtomicOutput::operator<<(char c) {
  if (used_ == buffer_.size()) flush();
  buffer_[used_++] = c;
  return *this;
}

AtomicOutput& AtomicOutput::operator<<(double value) {
  if (buffer_.size() - used_ < 32) flush();
  // Without a precision, to_chars gives the shortest decimal that parses back to `value`.
  const auto result = std::to_chars(buffer_.data() + used_, buffer_.data() + buffer_.size(), value);
  used_ = std::size_t(result.ptr - buffer_.data());
  return *this;
}

AtomicOutput& AtomicOutput::operator<<(std::int64_t value) {
  if (buffer_.size() - used_ < 24) flush();
  const auto result = std::to_chars(buffer_.data() + used_, buffer_.data() + buffer_.size(), value);
  used_ = std::size_t(result.ptr - buffer_.data());
  return *this;
}

void AtomicOutput::bytes(const void* data, std::size_t size) {
  if (buffer_.size() - used_ < size) flush();
  if (size >= buffer_.size()) {
    if (!file_) fail("write after finish");
    if (std::fwrite(data, 1, size, file_) != size) fail(std::strerror(errno));
    return;
  }
  std::memcpy(buffer_.data() + used_, data, size);
  used_ += size;
}

void AtomicOutput::finish() {
  if (!file_) return;
  flush();
  // fclose reports delayed write errors (e.g. a full disk); the temp file is then useless.
  const bool ok = std::fflush(file_) == 0 && !std::ferror(file_);
  const int error = errno;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) fail(std::strerror(ok ? errno : error));
}

void AtomicOutput::commit() {
  finish();
  std::error_code ec;
  fs::rename(temp_path_, path_, ec);
  if (ec) fail(ec.message());
  committed_ = true;
}

}  // namespace detail
}  // namespace cvt
