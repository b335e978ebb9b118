// INRIMAGE-4 (.inr, .inr.gz): read through CGAL's ImageIO, written directly (the format is a
// 256-byte-aligned text header followed by raw voxels). CGAL stays inside this file.
#include <CGAL/Image_3.h>
#include <zlib.h>

#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <locale>
#include <sstream>
#include <vector>

#include "base/errors.h"
#include "io/image_io.h"
#include "io/image_io_internal.h"
#include "base/memory.h"

namespace cvt {

namespace {
using namespace io_internal;

struct InrHeader {
  std::array<unsigned long long, 3> dims{0, 0, 0};
  unsigned long long vdim = 1;
  std::string type;              // "float", "signed fixed" or "unsigned fixed"
  int bits = 0;                  // PIXSIZE
  std::size_t header_bytes = 0;  // offset of the voxel data in the (uncompressed) stream
  std::array<double, 3> voxel_size{1, 1, 1};  // VX, VY, VZ
  std::string cpu;                            // byte order: decm/alpha/pc or sun/sgi

  std::string pixel_type() const {
    if (type == "float") return bits == 32 ? "float32" : bits == 64 ? "float64" : "";
    if (type != "signed fixed" && type != "unsigned fixed") return "";
    if (bits != 8 && bits != 16 && bits != 32 && bits != 64) return "";
    return (type == "signed fixed" ? "int" : "uint") + std::to_string(bits);
  }
};

struct GzCloser {
  void operator()(gzFile_s* f) const { gzclose(f); }
};
using GzFile = std::unique_ptr<gzFile_s, GzCloser>;

// Parses the header ourselves before CGAL reads the file: CGAL's ImageIO reports failures only
// on stderr, and we need dims and pixel type to check memory and completeness first.
InrHeader read_header(gzFile f, const std::string& path) {
  char line[300];
  auto next_line = [&]() -> bool {
    if (!gzgets(f, line, 257)) return false;
    line[std::strcspn(line, "\n")] = '\0';
    return true;
  };
  if (!next_line() || std::strcmp(line, "#INRIMAGE-4#{") != 0)
    throw InputError(path + ": not an INRIMAGE-4 file (bad, missing or truncated header)");
  InrHeader h;
  // Like CGAL, fields end at the first empty line or '#' line; what follows up to "##}" is
  // comments. Reading fields beyond that would judge a header CGAL reads differently (and
  // CGAL leaks its comment list when it then refuses the header).
  bool in_fields = true;
  for (int n = 0;; ++n) {
    if (n > 4096 || !next_line())
      throw InputError(path + ": truncated or corrupt INRIMAGE header (no end marker)");
    if (std::strncmp(line, "##}", 3) == 0) break;
    in_fields = in_fields && line[0] != '#' && line[0] != '\0';
    if (!in_fields) continue;
    std::string s(line);
    const std::size_t eq = s.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = s.substr(0, eq), value = s.substr(eq + 1);
    std::istringstream in(value);
    in.imbue(std::locale::classic());
    if (key == "XDIM")
      in >> h.dims[0];
    else if (key == "YDIM")
      in >> h.dims[1];
    else if (key == "ZDIM")
      in >> h.dims[2];
    else if (key == "VDIM")
      in >> h.vdim;
    else if (key == "PIXSIZE")
      in >> h.bits;
    else if (key == "VX" || key == "VY" || key == "VZ")
      in >> h.voxel_size[key[1] - 'X'];
    else if (key == "CPU")
      h.cpu = value;
    else if (key == "TYPE")  // matched by prefix, as CGAL does
      for (const char* t : {"float", "signed fixed", "unsigned fixed"})
        if (value.rfind(t, 0) == 0) h.type = t;
    if (in.fail()) throw InputError(path + ": bad INRIMAGE header field '" + s + "'");
  }
  h.header_bytes = std::size_t(gztell(f));
  return h;
}

}  // namespace

Image read_image_inr(const std::string& path, const ReadOptions& options) {
  InrHeader h;
  {
    GzFile f(gzopen(path.c_str(), "rb"));
    if (!f) throw InputError(path + ": cannot open (" + std::strerror(errno) + ")");
    h = read_header(f.get(), path);
    if (h.vdim != 1) {
      throw InputError(path + ": has " + std::to_string(h.vdim) +
                       " components per voxel (vector); cvtmesh needs a scalar 3D image");
    }
    // What CGAL would refuse with only a note on stderr.
    const auto& v = h.voxel_size;
    if (!(v[0] > 0 && v[1] > 0 && v[2] > 0))
      throw InputError(path + ": INRIMAGE voxel size VX/VY/VZ must be positive");
    bool known_cpu = false;
    for (const char* cpu : {"decm", "alpha", "pc", "sun", "sgi"})
      known_cpu = known_cpu || h.cpu.rfind(cpu, 0) == 0;
    if (!known_cpu) throw InputError(path + ": INRIMAGE header lacks a known CPU (byte order)");
    if (h.pixel_type().empty()) {
      throw InputError(path + ": unsupported INRIMAGE pixel type '" + h.type + "' of " +
                       std::to_string(h.bits) + " bits");
    }
    const std::size_t voxels = checked_voxel_count(h.dims, path);
    const std::size_t data_bytes = voxels * std::size_t(h.bits / 8);
    // Our float copy plus CGAL's buffer of the file's type.
    require_memory(voxels * sizeof(float) + data_bytes, options.max_bytes, path);
    f.reset();
    require_complete_file(path, h.header_bytes + data_bytes);
  }

  CGAL::Image_3 cgal_image;
  if (!cgal_image.read(path.c_str()) || !cgal_image.data())
    throw InputError(path + ": cannot read INRIMAGE data (corrupt file)");
  if (cgal_image.xdim() != h.dims[0] || cgal_image.ydim() != h.dims[1] ||
      cgal_image.zdim() != h.dims[2] || cgal_image.image()->wdim * 8 != std::size_t(h.bits))
    throw InputError(path + ": inconsistent INRIMAGE header");

  Image image;
  image.pixel_type = h.pixel_type();
  image.integer_valued = is_integer_pixel_type(image.pixel_type);
  Grid& g = image.voxels.grid;
  g.dims = {int(h.dims[0]), int(h.dims[1]), int(h.dims[2])};
  g.spacing = {cgal_image.vx(), cgal_image.vy(), cgal_image.vz()};
  g.origin = {cgal_image.tx(), cgal_image.ty(), cgal_image.tz()};  // 0 unless TX/TY/TZ given
  resize_large(image.voxels.data, g.voxel_count());
  convert_to_float(cgal_image.data(), image.pixel_type, g.voxel_count(), image.voxels.data.data(),
                   image.integer_valued, path);
  image.source = path;
  return image;
}

namespace {

template <class T>
bool write_voxels(gzFile f, const std::vector<float>& data) {
  std::vector<T> chunk;
  constexpr std::size_t kChunk = std::size_t(1) << 20;
  for (std::size_t begin = 0; begin < data.size(); begin += kChunk) {
    const std::size_t end = std::min(data.size(), begin + kChunk);
    chunk.resize(end - begin);
    for (std::size_t i = begin; i < end; ++i) {
      if constexpr (std::is_integral_v<T>)
        chunk[i - begin] = T(std::llrint(data[i]));  // range already checked
      else
        chunk[i - begin] = T(data[i]);
    }
    const unsigned bytes = unsigned(chunk.size() * sizeof(T));
    if (gzwrite(f, chunk.data(), bytes) != int(bytes)) return false;
  }
  return true;
}

std::string make_header(const Image& image, const std::string& type) {
  const Grid& g = image.grid();
  std::ostringstream h;
  h.imbue(std::locale::classic());
  h << std::setprecision(17);
  const bool is_float = type.rfind("float", 0) == 0;
  const int bits = std::stoi(type.substr(type.find_first_of("0123456789")));
  h << "#INRIMAGE-4#{\n"
    << "XDIM=" << g.dims[0] << "\nYDIM=" << g.dims[1] << "\nZDIM=" << g.dims[2] << "\nVDIM=1\n"
    << "TYPE="
    << (is_float         ? "float"
        : type[0] == 'u' ? "unsigned fixed"
                         : "signed fixed")
    << "\nPIXSIZE=" << bits << " bits\n"
    << (is_float ? "" : "SCALE=2**0\n")
    << "CPU=" << (std::endian::native == std::endian::little ? "decm" : "sun") << "\n"
    << "VX=" << g.spacing.x << "\nVY=" << g.spacing.y << "\nVZ=" << g.spacing.z << "\n";
  // CGAL reads the origin as TX/TY/TZ (floats); zero is the default and is left out.
  if (g.origin.x != 0) h << "TX=" << g.origin.x << "\n";
  if (g.origin.y != 0) h << "TY=" << g.origin.y << "\n";
  if (g.origin.z != 0) h << "TZ=" << g.origin.z << "\n";
  std::string text = h.str();
  // Pad with newlines so that the header, ending in "##}\n", fills whole 256-byte blocks.
  const std::size_t total = (text.size() + 4 + 255) / 256 * 256;
  text.append(total - text.size() - 4, '\n');
  return text + "##}\n";
}

}  // namespace

void write_image_inr(const Image& image, const std::string& path) {
  const auto& d = image.grid().direction;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (std::fabs(d[r * 3 + c] - (r == c ? 1.0 : 0.0)) > 1e-9)
        throw InputError("cannot write " + path +
                         ": INRIMAGE cannot store a non-identity direction (rotated image); "
                         "write .nii/.nii.gz/.nrrd/.mha instead");
  const std::string type = checked_write_pixel_type(image, path);
  const std::string header = make_header(image, type);
  // "T" writes uncompressed (transparent) through the same gz API for plain .inr.
  const bool gz = image_extension(path) == "inr.gz";
  errno = 0;
  GzFile f(gzopen(path.c_str(), gz ? "wb6" : "wbT"));
  if (!f) throw InputError("cannot write " + path + ": " + std::strerror(errno ? errno : EIO));
  bool ok = gzwrite(f.get(), header.data(), unsigned(header.size())) == int(header.size());
  if (ok) {
    if (type == "uint8")
      ok = write_voxels<std::uint8_t>(f.get(), image.voxels.data);
    else if (type == "int8")
      ok = write_voxels<std::int8_t>(f.get(), image.voxels.data);
    else if (type == "uint16")
      ok = write_voxels<std::uint16_t>(f.get(), image.voxels.data);
    else if (type == "int16")
      ok = write_voxels<std::int16_t>(f.get(), image.voxels.data);
    else if (type == "uint32")
      ok = write_voxels<std::uint32_t>(f.get(), image.voxels.data);
    else if (type == "int32")
      ok = write_voxels<std::int32_t>(f.get(), image.voxels.data);
    else if (type == "float64")
      ok = write_voxels<double>(f.get(), image.voxels.data);
    else
      ok = write_voxels<float>(f.get(), image.voxels.data);
  }
  int errnum = Z_OK;
  const std::string zerror = ok ? "" : gzerror(f.get(), &errnum);
  const bool closed = gzclose(f.release()) == Z_OK;
  if (!ok || !closed) {
    throw InputError("cannot write " + path + ": " +
                     (zerror.empty() ? std::string("write failed (disk full?)") : zerror));
  }
}

}  // namespace cvt
