// Format dispatch, atomic writing and the pixel conversions shared by the per-library readers.
#include "io/image_io.h"
#include "io/image_io_internal.h"

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <system_error>
#include <vector>

#include "base/errors.h"
#include "base/parallel_find.h"

namespace cvt {
namespace fs = std::filesystem;

// Helpers shared by itk_io.cpp, inr_io.cpp and slice_folder_io.cpp (declared there, not in
// image_io.h, so the public header stays small).
namespace io_internal {

// Collapses a multi-line library message into one line.
std::string one_line(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool space = std::isspace(static_cast<unsigned char>(c));
    if (space && (out.empty() || out.back() == ' ')) continue;
    out += space ? ' ' : c;
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

bool is_integer_pixel_type(const std::string& type) {
  return type.rfind("int", 0) == 0 || type.rfind("uint", 0) == 0;
}

// Validates dims read from a header and returns the voxel count; Grid stores dims as int.
std::size_t checked_voxel_count(const std::array<unsigned long long, 3>& dims,
                                const std::string& path) {
  if (dims[0] == 0 || dims[1] == 0 || dims[2] == 0)
    throw InputError(path + ": image is empty (0 voxels)");
  long double count = 1;
  for (auto d : dims) {
    if (d > (unsigned long long)INT_MAX)
      throw InputError(path + ": dimension " + std::to_string(d) + " is too large");
    count *= (long double)d;
  }
  if (count > (long double)(SIZE_MAX / 16)) throw InputError(path + ": image is too large");
  return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
}

// Throws unless `path` (plain or gzip) holds at least `expected` bytes once decompressed: some
// readers (niftilib, CGAL) only warn on stderr about a short file, or zero-fill the rest.
void require_complete_file(const std::string& path, std::size_t expected) {
  std::error_code ec;
  const std::size_t file_size = fs::file_size(path, ec);
  std::unique_ptr<gzFile_s, int (*)(gzFile)> f(gzopen(path.c_str(), "rb"), gzclose);
  char probe[2];
  if (ec || !f) throw InputError(path + ": cannot open");
  const int got = gzread(f.get(), probe, 2);  // gzdirect is only valid after a first read
  if (gzdirect(f.get()) || got < 0) {
    if (file_size >= expected) return;
    throw InputError(path + ": truncated (" + std::to_string(file_size) + " of " +
                     std::to_string(expected) + " bytes)");
  }
  // A gzip file ends with its uncompressed size mod 2^32: a cheap check that holds for any
  // complete single-member file. Only when it disagrees do we decompress to count.
  std::ifstream raw(path, std::ios::binary);
  unsigned char t[4] = {0, 0, 0, 0};
  if (file_size >= 4 && raw.seekg(std::streamoff(file_size - 4)) &&
      raw.read(reinterpret_cast<char*>(t), 4)) {
    const std::uint32_t isize = t[0] | t[1] << 8 | t[2] << 16 | std::uint32_t(t[3]) << 24;
    if (isize == std::uint32_t(expected)) return;
  }
  std::vector<char> buffer(1 << 20);
  std::size_t total = std::size_t(got);
  int n = 0;
  while (total < expected && (n = gzread(f.get(), buffer.data(), unsigned(buffer.size()))) > 0)
    total += std::size_t(n);
  if (total < expected) {
    throw InputError(path + ": truncated or corrupt gzip data (" + std::to_string(total) + " of " +
                     std::to_string(expected) + " bytes)");
  }
}

namespace {
template <class T>
void convert_typed(const T* src, std::size_t count, float* dst, bool labels,
                   const std::string& path) {
  // Floats hold every integer up to 2^24 exactly; beyond that two labels could merge.
  constexpr double kMaxLabel = 16777216.0;
  // In parallel; the label reported is the first one out of range, as in a serial scan.
  const std::size_t bad = parallel_find_first(
      count,
      [&](std::size_t i) {
        const double v = double(src[i]);
        if (labels && std::fabs(v) > kMaxLabel) return true;
        dst[i] = float(v);
        return false;
      },
      std::size_t(1) << 16);
  if (bad < count) {
    std::ostringstream label;
    label << std::fixed << std::setprecision(0) << double(src[bad]);
    throw InputError(path + ": label " + label.str() +
                     " exceeds 2^24 in magnitude and cannot be stored exactly");
  }
}
}  // namespace

// Converts `count` values of `src_type` ("uint8" ... "float64") to float. With `labels`,
// refuses values a float cannot hold exactly (src_type may then be a float type carrying ints).
void convert_to_float(const void* src, const std::string& src_type, std::size_t count, float* dst,
                      bool labels, const std::string& path) {
  if (src_type == "uint8") return convert_typed((const std::uint8_t*)src, count, dst, labels, path);
  if (src_type == "int8") return convert_typed((const std::int8_t*)src, count, dst, labels, path);
  if (src_type == "uint16")
    return convert_typed((const std::uint16_t*)src, count, dst, labels, path);
  if (src_type == "int16") return convert_typed((const std::int16_t*)src, count, dst, labels, path);
  if (src_type == "uint32")
    return convert_typed((const std::uint32_t*)src, count, dst, labels, path);
  if (src_type == "int32") return convert_typed((const std::int32_t*)src, count, dst, labels, path);
  if (src_type == "uint64")
    return convert_typed((const std::uint64_t*)src, count, dst, labels, path);
  if (src_type == "int64") return convert_typed((const std::int64_t*)src, count, dst, labels, path);
  if (src_type == "float32") return convert_typed((const float*)src, count, dst, labels, path);
  if (src_type == "float64") return convert_typed((const double*)src, count, dst, labels, path);
  throw InputError(path + ": unsupported pixel type '" + src_type + "'");
}

// The pixel type to write `image` with (empty → float32); throws when a value does not fit it.
std::string checked_write_pixel_type(const Image& image, const std::string& path) {
  std::string type = image.pixel_type.empty() ? "float32" : image.pixel_type;
  // Types we read but do not write: half floats widen; 64-bit labels (all < 2^24) narrow.
  if (type == "float16") type = "float32";
  if (type == "int64" || type == "uint64") type = "int32";
  if (type == "float32" || type == "float64") return type;
  struct Range {
    const char* name;
    double lo, hi;
  };
  static constexpr Range kRanges[] = {
      {"uint8", 0, 255},        {"int8", -128, 127},        {"uint16", 0, 65535},
      {"int16", -32768, 32767}, {"uint32", 0, 4294967295.}, {"int32", -2147483648., 2147483647.}};
  const auto* range = std::find_if(std::begin(kRanges), std::end(kRanges),
                                   [&](const Range& r) { return type == r.name; });
  if (range == std::end(kRanges))
    throw InputError("cannot write " + path + ": unsupported pixel type '" + type + "'");
  const double lo = range->lo, hi = range->hi;
  for (float v : image.voxels.data) {
    const double r = std::nearbyint(double(v));
    if (!(r >= lo && r <= hi)) {  // also catches NaN
      std::ostringstream value;
      value << v;
      throw InputError("cannot write " + path + ": value " + value.str() +
                       " does not fit pixel type " + type);
    }
  }
  return type;
}

}  // namespace io_internal

namespace {

const char* const kReadFormats =
    ".nii .nii.gz .nrrd .nhdr .mha .mhd .inr .inr.gz, a DICOM folder, a folder of "
    ".tif/.tiff/.png slices";
const char* const kWriteFormats = ".nii .nii.gz .nrrd .nhdr .mha .mhd .inr .inr.gz";

bool is_itk_extension(const std::string& e) {
  return e == "nii" || e == "nii.gz" || e == "nrrd" || e == "nhdr" || e == "mha" || e == "mhd";
}
bool is_inr_extension(const std::string& e) {
  return e == "inr" || e == "inr.gz";
}
bool is_slice_extension(const std::string& e) {
  return e == "tif" || e == "tiff" || e == "png";
}

// True when the folder holds at least one visible 2D slice file.
bool folder_has_slices(const std::string& folder) {
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!name.empty() && name[0] != '.' && it->is_regular_file(ec) &&
        is_slice_extension(image_extension(name)))
      return true;
  }
  return false;
}

void replace_all(std::string& text, const std::string& from, const std::string& to) {
  if (from.empty()) return;
  for (std::size_t pos = 0; (pos = text.find(from, pos)) != std::string::npos; pos += to.size())
    text.replace(pos, from.size(), to);
}

// MetaIO prints multi-line complaints on std::cerr before it fails (e.g. a NaN spacing); the
// InputError says what the user needs, so that text is held back while a file is read.
class HoldBackCerr {
 public:
  HoldBackCerr() : saved_(std::cerr.rdbuf(held_.rdbuf())) {}
  ~HoldBackCerr() { std::cerr.rdbuf(saved_); }
  HoldBackCerr(const HoldBackCerr&) = delete;
  HoldBackCerr& operator=(const HoldBackCerr&) = delete;

 private:
  std::ostringstream held_;
  std::streambuf* saved_;
};

}  // namespace

std::string image_extension(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  const std::size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot == 0) return "";
  if (name.compare(dot, std::string::npos, ".gz") == 0) {
    const std::size_t inner = name.rfind('.', dot - 1);
    if (inner != std::string::npos && inner != 0) return name.substr(inner + 1);
  }
  return name.substr(dot + 1);
}

Image read_image(const std::string& path, const ReadOptions& options) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw InputError(path + ": no such file");
  Image image;
  const HoldBackCerr quiet;
  if (fs::is_directory(status)) {
    // A folder: slices when it holds any (a DICOM folder rarely has .png/.tif files in it).
    image = folder_has_slices(path) ? read_slice_folder(path, options)
                                    : read_dicom_series_itk(path, options);
  } else {
    const std::string ext = image_extension(path);
    if (is_itk_extension(ext)) {
      image = read_image_itk(path, options);
    } else if (is_inr_extension(ext)) {
      image = read_image_inr(path, options);
    } else if (is_slice_extension(ext)) {
      throw InputError(path + ": is 2D; cvtmesh needs a 3D image (give the folder of slices)");
    } else {
      throw InputError(path + ": unsupported image format '." + ext +
                       "' (supported: " + kReadFormats + ")");
    }
  }
  if (image.voxels.grid.voxel_count() == 0) throw InputError(path + ": image is empty (0 voxels)");
  // Some headers parse NaN or 0 as a spacing; every later stage divides by it.
  const Grid& g = image.voxels.grid;
  for (int a = 0; a < 3; ++a)
    if (!(std::isfinite(g.spacing[a]) && g.spacing[a] > 0))
      throw InputError(path + ": voxel spacing " + std::to_string(g.spacing[a]) + " along axis " +
                       std::to_string(a) + " (must be a positive number)");
  bool finite_frame = true;
  for (int a = 0; a < 3; ++a) finite_frame = finite_frame && std::isfinite(g.origin[a]);
  for (double d : g.direction) finite_frame = finite_frame && std::isfinite(d);
  if (!finite_frame) throw InputError(path + ": origin or direction is not finite");
  image.source = path;
  return image;
}

void write_image(const Image& image, const std::string& path) {
  const std::string ext = image_extension(path);
  const bool itk = is_itk_extension(ext), inr = is_inr_extension(ext);
  if (!itk && !inr) {
    throw InputError("cannot write " + path + ": unsupported image format '." + ext +
                     "' (supported: " + kWriteFormats + ")");
  }
  if (image.voxels.grid.voxel_count() == 0)
    throw InputError("cannot write " + path + ": image is empty (0 voxels)");
  if (image.voxels.data.size() != image.voxels.grid.voxel_count())
    throw InputError("cannot write " + path + ": voxel data does not match the image dims");

  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError("cannot write " + path + ": " +
                     (fs::exists(dir, ec) ? dir.string() + " is not a folder"
                                          : "folder " + dir.string() + " does not exist"));
  }
  if (fs::is_directory(target, ec)) throw InputError("cannot write " + path + ": is a folder");

  // Write into a private folder beside the target, under the final file name: ITK picks the
  // format by extension, and .mhd/.nhdr write a data file named after the header that must be
  // moved along. The header is renamed last, so readers never see it before its data.
  static std::atomic<unsigned> counter{0};
  fs::path tmp_dir;
  for (bool created = false; !created;) {  // skip names left over by a crashed process
    tmp_dir =
        dir / (".cvtmesh-tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    created = fs::create_directory(tmp_dir, ec);
    if (ec) {
      throw InputError("cannot write " + path + ": cannot create files in folder " + dir.string() +
                       " (" + ec.message() + ")");
    }
  }
  const fs::path tmp_file = tmp_dir / target.filename();
  try {
    if (itk)
      write_image_itk(image, tmp_file.string());
    else
      write_image_inr(image, tmp_file.string());
    for (const auto& entry : fs::directory_iterator(tmp_dir)) {
      if (entry.path().filename() != target.filename())
        fs::rename(entry.path(), dir / entry.path().filename());
    }
    fs::rename(tmp_file, target);
  } catch (const std::exception& e) {
    fs::remove_all(tmp_dir, ec);
    std::string message = io_internal::one_line(e.what());
    replace_all(message, tmp_file.string(), path);
    if (message.rfind("cannot write ", 0) != 0) message = "cannot write " + path + ": " + message;
    throw InputError(message);
  }
  fs::remove_all(tmp_dir, ec);
}

}  // namespace cvt
