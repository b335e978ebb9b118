// A folder of 2D .tif/.tiff/.png slices read with OpenImageIO into one 3D image.
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <vector>

#include "base/errors.h"
#include "io/image_io.h"
#include "io/image_io_internal.h"
#include "base/memory.h"

namespace cvt {

namespace {
using namespace io_internal;
namespace fs = std::filesystem;

// Name order with digit runs compared as numbers, so "s2.png" comes before "s10.png";
// identical to plain name order for zero-padded numbering.
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit((unsigned char)a[i]) && std::isdigit((unsigned char)b[j])) {
      std::size_t i_end = i, j_end = j;
      while (i_end < a.size() && std::isdigit((unsigned char)a[i_end])) ++i_end;
      while (j_end < b.size() && std::isdigit((unsigned char)b[j_end])) ++j_end;
      std::string x = a.substr(i, i_end - i), y = b.substr(j, j_end - j);
      x.erase(0, std::min(x.find_first_not_of('0'), x.size()));
      y.erase(0, std::min(y.find_first_not_of('0'), y.size()));
      if (x.size() != y.size()) return x.size() < y.size();
      if (x != y) return x < y;
      i = i_end, j = j_end;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
  return a < b;  // e.g. "s01" vs "s1": any fixed order
}

std::vector<std::string> list_slices(const std::string& folder) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const std::string ext = image_extension(name);
    if (!name.empty() && name[0] != '.' && it->is_regular_file(ec) &&
        (ext == "tif" || ext == "tiff" || ext == "png"))
      names.push_back(name);
  }
  if (ec) throw InputError(folder + ": cannot list folder (" + ec.message() + ")");
  std::sort(names.begin(), names.end(), natural_less);
  return names;
}

// Our pixel type name for an OIIO channel format; "" when unsupported.
std::string pixel_type_name(OIIO::TypeDesc format) {
  switch (format.basetype) {
    case OIIO::TypeDesc::UINT8:
      return "uint8";
    case OIIO::TypeDesc::INT8:
      return "int8";
    case OIIO::TypeDesc::UINT16:
      return "uint16";
    case OIIO::TypeDesc::INT16:
      return "int16";
    case OIIO::TypeDesc::UINT32:
      return "uint32";
    case OIIO::TypeDesc::INT32:
      return "int32";
    case OIIO::TypeDesc::HALF:
      return "float16";
    case OIIO::TypeDesc::FLOAT:
      return "float32";
    case OIIO::TypeDesc::DOUBLE:
      return "float64";
    default:
      return "";
  }
}

std::unique_ptr<OIIO::ImageInput> open_slice(const std::string& file) {
  auto input = OIIO::ImageInput::open(file);
  if (!input) throw InputError(file + ": cannot read image (" + one_line(OIIO::geterror()) + ")");
  return input;
}

}  // namespace

Image read_slice_folder(const std::string& folder, const ReadOptions& options) {
  const std::vector<std::string> names = list_slices(folder);
  if (names.empty()) throw InputError(folder + ": folder holds no .tif/.tiff/.png slices");
  if (names.size() == 1) {
    throw InputError(folder + ": holds a single slice (" + names[0] +
                     "), which is 2D; cvtmesh needs a 3D image");
  }
  const Vec3& s = options.slice_spacing_mm;
  if (!(s.x > 0 && s.y > 0 && s.z > 0) || !std::isfinite(s.x + s.y + s.z))
    throw InputError(folder + ": slice spacing must be positive (mm)");

  // The first slice fixes size and pixel type for all.
  const std::string first = (fs::path(folder) / names[0]).string();
  OIIO::ImageSpec spec = open_slice(first)->spec();
  if (spec.nchannels != 1) {
    throw InputError(first + ": has " + std::to_string(spec.nchannels) +
                     " channels (colour?); cvtmesh needs single-channel grey slices");
  }
  if (spec.depth > 1) throw InputError(first + ": is a 3D image, not a 2D slice");
  const std::string pixel_type = pixel_type_name(spec.format);
  if (pixel_type.empty())
    throw InputError(first + ": unsupported pixel type " + std::string(spec.format.c_str()));
  // OIIO would normalise integers to 0..1 when asked for float: read the stored type instead.
  // Half floats are read as float32 (conversion between float types keeps the values).
  const OIIO::TypeDesc read_format = pixel_type == "float16" ? OIIO::TypeDesc::FLOAT : spec.format;
  const std::string read_type = pixel_type == "float16" ? "float32" : pixel_type;

  const std::size_t nx = std::size_t(spec.width), ny = std::size_t(spec.height);
  const std::size_t voxels = checked_voxel_count({nx, ny, names.size()}, folder);
  const std::size_t slice_voxels = nx * ny;
  require_memory(voxels * sizeof(float) + slice_voxels * read_format.size(), options.max_bytes,
                 folder);

  Image image;
  image.pixel_type = pixel_type;
  image.integer_valued = is_integer_pixel_type(pixel_type);
  Grid& g = image.voxels.grid;
  g.dims = {int(nx), int(ny), int(names.size())};
  g.spacing = s;
  image.voxels.data.resize(voxels);
  std::vector<unsigned char> buffer(slice_voxels * read_format.size());
  for (std::size_t k = 0; k < names.size(); ++k) {
    const std::string file = (fs::path(folder) / names[k]).string();
    auto input = open_slice(file);
    const OIIO::ImageSpec& sk = input->spec();
    if (sk.width != spec.width || sk.height != spec.height || sk.nchannels != spec.nchannels ||
        sk.format != spec.format || sk.depth != spec.depth) {
      throw InputError(file + ": is " + std::to_string(sk.width) + "x" + std::to_string(sk.height) +
                       " " + pixel_type_name(sk.format) + " with " + std::to_string(sk.nchannels) +
                       " channel(s), unlike " + names[0] + " (" + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + " " + pixel_type + ")");
    }
    if (!input->read_image(0, 0, 0, 1, read_format, buffer.data()))
      throw InputError(file + ": cannot read pixels (" + one_line(input->geterror()) + ")");
    convert_to_float(buffer.data(), read_type, slice_voxels,
                     image.voxels.data.data() + k * slice_voxels, image.integer_valued, file);
  }
  image.source = folder;
  return image;
}

}  // namespace cvt
