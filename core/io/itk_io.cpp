// ITK readers/writers: NIfTI, NRRD, MetaImage and DICOM series (GDCM). ITK stays inside this file.
#include <itkGDCMImageIO.h>
#include <itkGDCMImageIOFactory.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOFactory.h>
#include <itkImageSeriesReader.h>
#include <itkMetaImageIO.h>
#include <itkMetaImageIOFactory.h>
#include <itkNiftiImageIO.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIO.h>
#include <itkNrrdImageIOFactory.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <new>
#include <set>
#include <sstream>
#include <vector>

#include "base/errors.h"
#include "io/image_io.h"
#include "io/image_io_internal.h"
#include "base/memory.h"

namespace cvt {

namespace {
using namespace io_internal;

// Explicit registration: we do not use ITK_USE_FILE's generated registration manager, so only
// the formats we document are tried, in a known order.
void register_itk_factories() {
  static std::once_flag once;
  std::call_once(once, [] {
    itk::NiftiImageIOFactory::RegisterOneFactory();
    itk::NrrdImageIOFactory::RegisterOneFactory();
    itk::MetaImageIOFactory::RegisterOneFactory();
    itk::GDCMImageIOFactory::RegisterOneFactory();
    // ITK warnings are multi-line stderr text; our errors carry what the user needs.
    itk::Object::GlobalWarningDisplayOff();
  });
}

// ITK's description without its "ITK ERROR: Class(0x...): " prefix; for NRRD only teem's
// innermost reason (its messages nest "[nrrd] ...: trouble" several levels deep).
std::string describe(const itk::ExceptionObject& e) {
  std::string text = one_line(e.GetDescription());
  const std::size_t nrrd = text.rfind("[nrrd] ");
  if (nrrd != std::string::npos) return text.substr(nrrd + 7);
  for (const char* prefix : {"ITK ERROR: ", "itk::ERROR: "}) {
    if (text.rfind(prefix, 0) != 0) continue;
    const std::size_t end = text.find("): ");
    text = end == std::string::npos ? text.substr(std::strlen(prefix)) : text.substr(end + 3);
  }
  return text;
}

// "uint8", "int16", "float32", ... from ITK's component type (sizes taken from the IO, since
// `long` differs between platforms).
std::string pixel_type_name(const itk::ImageIOBase& io) {
  // ITK names: "unsigned_char", "short", "long_long", "float", "double", "unknown", ...
  const std::string name = itk::ImageIOBase::GetComponentTypeAsString(io.GetComponentType());
  const std::string bits = std::to_string(io.GetComponentSize() * 8);
  if (name == "unknown") return "";
  if (name == "float" || name == "double") return "float" + bits;
  return (name.rfind("unsigned", 0) == 0 ? "uint" : "int") + bits;
}

// Rejects 2D, 4D and vector images; returns the 3D dims.
std::array<unsigned long long, 3> checked_3d_dims(const itk::ImageIOBase& io,
                                                  const std::string& path) {
  const unsigned nd = io.GetNumberOfDimensions();
  if (nd < 3) throw InputError(path + ": is " + std::to_string(nd) + "D; cvtmesh needs a 3D image");
  unsigned long long extra = 1;  // volumes along dimensions beyond the third
  for (unsigned d = 3; d < nd; ++d) extra *= io.GetDimensions(d);
  if (extra > 1) {
    throw InputError(path + ": is " + std::to_string(nd) + "D (" + std::to_string(extra) +
                     " volumes); cvtmesh needs a 3D image");
  }
  if (io.GetNumberOfComponents() != 1) {
    throw InputError(path + ": has " + std::to_string(io.GetNumberOfComponents()) +
                     " components per voxel (vector/RGB); cvtmesh needs a scalar 3D image");
  }
  return {io.GetDimensions(0), io.GetDimensions(1), io.GetDimensions(2)};
}

// "1e+30", "nan": short text for a number read from a file.
std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// The start of a NIfTI file (plain or gzip), read by us before and after ITK judges it.
struct NiftiHeader {
  unsigned char bytes[540] = {};  // a NIfTI-2 header; NIfTI-1 uses the first 348
  int size = 0;                   // sizeof_hdr: 348 (NIfTI-1), 540 (NIfTI-2), else 0
  bool swap = false;              // the file's byte order is not ours

  template <class T>
  T load(int offset) const {
    unsigned char b[sizeof(T)];
    std::memcpy(b, bytes + offset, sizeof b);
    if (swap) std::reverse(b, b + sizeof b);
    T value;
    std::memcpy(&value, b, sizeof b);
    return value;
  }
};

NiftiHeader read_nifti_header(const std::string& path) {
  NiftiHeader h;
  std::unique_ptr<gzFile_s, int (*)(gzFile)> f(gzopen(path.c_str(), "rb"), gzclose);
  const int got = f ? gzread(f.get(), h.bytes, sizeof h.bytes) : -1;
  for (bool swap : {false, true}) {
    h.swap = swap;
    if (h.load<std::int32_t>(0) == 540 && got >= 540) {
      h.size = 540;
      return h;
    }
  }
  // Anything else of 348 bytes or more is taken as NIfTI-1 (or ANALYZE 7.5): niftilib accepts
  // more magics and sizes than the standard names, and a stricter test here let such headers
  // past the checks. The byte order is the one that makes dim[0] 1..7 (sizeof_hdr decides
  // when dim[0] is 0), as niftilib's need_nhdr_swap does.
  if (got < 348) return h;
  const auto in_order = [&](bool swap) {
    h.swap = swap;
    const std::int16_t dim0 = h.load<std::int16_t>(40);
    return dim0 != 0 ? dim0 >= 1 && dim0 <= 7 : h.load<std::int32_t>(0) == 348;
  };
  h.swap = !in_order(false) && in_order(true);
  h.size = 348;
  return h;
}

// niftilib turns pixdim, the quaternion, the offsets and the sform into a float matrix that ITK
// decomposes (vnl_svd), which aborts the process on a NaN or an infinity. Refused first.
void require_finite_nifti_geometry(const std::string& path) {
  const NiftiHeader h = read_nifti_header(path);
  if (h.size != 348) return;  // ITK 5.2 reads NIfTI-1 only
  struct Field {
    const char* name;
    int offset, count;
  };
  static constexpr Field kFields[] = {
      {"pixdim", 76, 4}, {"quatern", 256, 3}, {"qoffset", 268, 3}, {"srow", 280, 12}};
  for (const Field& field : kFields) {
    for (int i = 0; i < field.count; ++i) {
      const float v = h.load<float>(field.offset + 4 * i);
      // Beyond 1e15 mm no image is real, and squares of such values overflow float.
      if (!(std::fabs(v) <= 1e15f)) {
        throw InputError(path + ": corrupt NIfTI header (" + field.name + " value " +
                         number_text(v) + ")");
      }
    }
  }
}

// niftilib reads a short .nii/.nii.gz without failing (it zero-fills and at most warns), so we
// compare the file with vox_offset + data size from the header ourselves.
void require_complete_nifti(const std::string& path, std::size_t data_bytes) {
  const NiftiHeader h = read_nifti_header(path);
  double vox_offset = -1;
  if (h.size == 348) vox_offset = h.load<float>(108);
  if (h.size == 540) vox_offset = double(h.load<std::int64_t>(168));
  if (std::isnan(vox_offset) || vox_offset > 1e15) {  // a float from the file, not yet a size
    throw InputError(path + ": corrupt NIfTI header (vox_offset " + number_text(vox_offset) + ")");
  }
  // niftilib reads data from offset 0 when vox_offset is negative (ANALYZE headers).
  if (h.size) require_complete_file(path, std::size_t(std::max(vox_offset, 0.0)) + data_bytes);
}

// MetaIO parses its header into fixed buffers: a field name of 255 characters or more, or a
// value that long (Name, Comment), overflows them, and NDims sizes arrays of 10 dimensions and
// 4096 values. A header line without '=' or ':' can make it read on into the voxel data as
// header; control characters and repeated fields corrupted its heap. All of these are refused
// before MetaIO sees the file, and so are spacings that are not positive finite numbers (MetaIO
// fails on NaN with "Invalid argument", ITK on 0 with its own words, and ITK's reader quietly
// flips the axis of a negative one).
void require_sane_metaimage_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::set<std::string> keys;
  double ndims = 0;
  std::vector<std::pair<std::string, int>> spacing_values;  // (field, how many values)
  for (int number = 1; std::getline(in, line); ++number) {
    const auto fail = [&](const std::string& why) {
      throw InputError(path + ": bad MetaImage header line " + std::to_string(number) + " (" + why +
                       ")");
    };
    if (line.size() >= 255) fail("longer than 254 characters");
    // MetaIO handles neither well: it corrupted its heap on such a header.
    for (char c : line)
      if (std::iscntrl(static_cast<unsigned char>(c)) && c != '\t' && c != '\r')
        fail("control character");
    const std::size_t begin = line.find_first_not_of(" \t\r\v\f");
    if (begin == std::string::npos) continue;
    // MetaIO's field name also ends at a carriage return; its value starts after the next
    // '=' or ':'.
    const std::size_t name_end = line.find_first_of("=:\r", begin);
    const std::size_t separator = line.find_first_of("=:", begin);
    if (separator == std::string::npos) fail("no '=' after the field name");
    std::string key = line.substr(begin, name_end - begin);
    key.erase(key.find_last_not_of(" \t") + 1);
    if (!keys.insert(key).second) fail("'" + key + "' given twice");
    if (key == "ElementDataFile") {
      // MetaIO passes a numbered file pattern to snprintf as the format (with one int).
      const std::string value = line.substr(separator + 1);
      if (value.find_first_not_of(" \t\r") == std::string::npos) fail("ElementDataFile is empty");
      // MetaIO joins the name to the header's folder in fixed buffers (a long or non-ASCII
      // name overflowed one).
      for (char c : value)
        if (c != '\t' && c != '\r' && (c < 0x20 || c > 0x7e))
          fail("ElementDataFile is not plain ASCII");
      if (std::filesystem::path(path).parent_path().string().size() + value.size() >= 200)
        fail("ElementDataFile path too long");
      const std::size_t percent = value.find('%');
      if (percent != std::string::npos) {
        std::size_t end = percent + 1;
        while (end < value.size() && std::isdigit(static_cast<unsigned char>(value[end]))) ++end;
        if (end >= value.size() || value[end] != 'd' ||
            value.find('%', percent + 1) != std::string::npos)
          fail("a file pattern in ElementDataFile needs exactly one %d");
        // "pattern first last step": MetaIO divides by the step (0 crashed it).
        std::istringstream words(value);
        std::string pattern;
        long long first = 0, last = -1, step = 0;
        if (!(words >> pattern >> first >> last >> step) || step < 1 || last < first ||
            (last - first) / step > 100000)
          fail("ElementDataFile pattern needs whole numbers first <= last and step >= 1");
      }
      for (const auto& [field, count] : spacing_values)
        if (count < ndims)
          throw InputError(path + ": " + field + " gives " + std::to_string(count) +
                           " voxel spacings for NDims = " + std::to_string(int(ndims)));
      return;  // the voxel data follows
    }
    if (key == "ElementSpacing" || key == "ElementSize") {  // MetaIO takes the size as spacing
      std::istringstream values(line.substr(separator + 1));
      spacing_values.push_back({key, 0});
      for (std::string value; values >> value; ++spacing_values.back().second) {
        char* end = nullptr;
        const double mm = std::strtod(value.c_str(), &end);
        if (end != value.c_str() + value.size() || !(std::isfinite(mm) && mm > 0))
          throw InputError(path + ": voxel spacing " + value + " (" + key +
                           ") is not a positive finite number");
      }
    }
    if (key == "NDims") {
      char* end = nullptr;
      ndims = std::strtod(line.c_str() + separator + 1, &end);
      if (!(ndims >= 1 && ndims <= 10) || ndims != std::floor(ndims))
        fail("NDims must be a whole number from 1 to 10");
    }
  }
}

// MetaIO's inflate loop never ends on some corrupt streams (found by fuzzing: a hang in
// MET_PerformUncompression): inflate the data ourselves first, in chunks, and refuse a stream
// that fails or ends before `data_bytes`. Every step consumes input or makes output, or stops.
void require_inflatable(const std::string& path, std::ifstream& in, std::size_t compressed,
                        std::size_t data_bytes) {
  z_stream s{};
  if (inflateInit2(&s, 47) != Z_OK)  // 47: zlib or gzip header, as MetaIO reads it
    throw InputError(path + ": cannot start decompressing its voxel data");
  std::vector<unsigned char> input(1 << 16), output(1 << 16);
  std::size_t left = compressed, produced = 0;
  while (produced < data_bytes) {
    if (s.avail_in == 0 && left > 0) {
      in.read(reinterpret_cast<char*>(input.data()), std::streamsize(std::min(left, input.size())));
      const std::size_t got = std::size_t(std::max<std::streamsize>(in.gcount(), 0));
      if (got == 0) break;
      left -= got;
      s.next_in = input.data();
      s.avail_in = uInt(got);
    }
    s.next_out = output.data();
    s.avail_out = uInt(output.size());
    const int err = inflate(&s, Z_NO_FLUSH);
    produced += output.size() - s.avail_out;
    if (err != Z_OK) break;  // the end of the stream, an error, or no input left
  }
  inflateEnd(&s);
  if (produced < data_bytes)
    throw InputError(path + ": its compressed voxel data is corrupt (it inflates to " +
                     std::to_string(produced) + " of " + std::to_string(data_bytes) + " bytes)");
}

// MetaIO likewise only prints "data not read completely": check the data size ourselves
// (compressed data against CompressedDataSize, raw data against the voxel count). Without
// CompressedDataSize MetaIO sizes its buffer from the stream, which can be -1 bytes.
void require_complete_metaimage(const std::string& path, std::size_t data_bytes) {
  std::ifstream in(path, std::ios::binary);
  std::string line, data_file;
  bool compressed = false;
  double compressed_size = 0;
  auto trim = [](std::string t) {
    const auto b = t.find_first_not_of(" \t\r"), e = t.find_last_not_of(" \t\r");
    return b == std::string::npos ? std::string() : t.substr(b, e - b + 1);
  };
  bool found_data_file = false;
  while (!found_data_file && std::getline(in, line)) {
    const std::size_t eq = line.find_first_of("=:");  // MetaIO's two separators
    if (eq == std::string::npos) continue;
    const std::string key = trim(line.substr(0, eq)), value = trim(line.substr(eq + 1));
    // MetaIO looks at the first character only.
    if (key == "CompressedData") compressed = !value.empty() && std::strchr("Tt1", value[0]);
    if (key == "CompressedDataSize") compressed_size = std::strtod(value.c_str(), nullptr);
    if (key == "ElementDataFile") {
      data_file = value;
      found_data_file = true;
    }
  }
  if (compressed && !(compressed_size >= 1 && compressed_size <= 1e18))
    throw InputError(path + ": compressed MetaImage without a valid CompressedDataSize");
  const std::size_t needed = compressed ? std::size_t(compressed_size) : data_bytes;
  // Lists and numbered file patterns are left to MetaIO.
  if (data_file.empty() || data_file == "LIST" || data_file.find('%') != std::string::npos) return;
  std::error_code ec;
  std::size_t have = 0;
  std::filesystem::path file = path;
  std::streamoff offset = 0;
  if (data_file == "LOCAL") {
    offset = in.tellg();
    have = offset < 0 ? 0 : std::filesystem::file_size(path, ec) - std::size_t(offset);
  } else {
    file = data_file;
    if (file.is_relative()) file = std::filesystem::path(path).parent_path() / file;
    have = std::filesystem::file_size(file, ec);
    if (ec) throw InputError(path + ": its data file " + file.string() + " is missing");
  }
  if (have < needed) {
    throw InputError(path + ": truncated (" + std::to_string(have) + " of " +
                     std::to_string(needed) + " bytes of voxel data)");
  }
  if (!compressed || offset < 0) return;
  std::ifstream data(file, std::ios::binary);
  data.seekg(offset);
  require_inflatable(path, data, needed, data_bytes);
}

// teem overflows a stack buffer (stack smashing, abort) on a header line of about 1000
// characters or more: refused first, with a margin; real headers keep lines far shorter.
void require_sane_nrrd_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.size() >= 900) {
      throw InputError(path + ": bad NRRD header line " + std::to_string(number) +
                       " (longer than 899 characters)");
    }
    if (line.empty() || line == "\r") return;  // the data follows
  }
}

// Bytes of data a zlib or gzip stream starting at `offset` of `path` inflates to, counting no
// further than `limit` (so a stream that really is that large costs time, never memory).
std::size_t inflated_size(const std::string& path, std::size_t offset, std::size_t limit) {
  std::ifstream in(path, std::ios::binary);
  in.seekg(std::streamoff(offset));
  z_stream z{};
  if (!in || inflateInit2(&z, 15 + 32) != Z_OK) return 0;  // 15 + 32: zlib or gzip header
  std::vector<unsigned char> input(1 << 16), output(1 << 16);
  std::size_t total = 0;
  int status = Z_OK;
  while (total < limit && status != Z_STREAM_END) {
    if (z.avail_in == 0) {
      in.read(reinterpret_cast<char*>(input.data()), std::streamsize(input.size()));
      z.next_in = input.data();
      z.avail_in = uInt(in.gcount());
      if (z.avail_in == 0) break;  // the file ends inside the stream
    }
    z.next_out = output.data();
    z.avail_out = uInt(output.size());
    status = inflate(&z, Z_NO_FLUSH);
    if (status != Z_OK && status != Z_STREAM_END) break;  // corrupt: what came out so far
    total += output.size() - z.avail_out;
  }
  inflateEnd(&z);
  return total;
}

// teem allocates (and zeroes) the whole image a NRRD header announces before it reads a byte,
// so a 100-byte file claiming gigavoxels costs gigabytes. The data actually present is checked
// first: raw bytes, gzip output, or at least the characters text and hex need.
void require_complete_nrrd(const std::string& path, std::size_t data_bytes, std::size_t values) {
  std::ifstream in(path, std::ios::binary);
  std::string line, encoding = "raw", data_file;
  long long byte_skip = 0;
  bool header_ended = false;
  for (bool first = true; std::getline(in, line); first = false) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) {
      header_ended = true;
      break;
    }
    if (first || line[0] == '#') continue;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string value = line.substr(colon + 1);
    if (!value.empty() && value[0] == '=') continue;        // a key/value pair, not a field
    value.erase(std::min(value.size(), value.find('\0')));  // teem reads C strings
    value.erase(0, value.find_first_not_of(" \t"));
    value.erase(std::min(value.size(), value.find_last_not_of(" \t") + 1));
    const std::string key = line.substr(0, colon);
    if (key == "encoding") encoding = value;
    if (key == "byte skip") byte_skip = std::atoll(value.c_str());
    if (key == "data file" || key == "datafile") data_file = value;
  }
  std::error_code ec;
  std::filesystem::path file = path;
  std::size_t start = 0;
  if (!data_file.empty()) {
    // Lists and numbered file patterns are left to teem.
    if (data_file.rfind("LIST", 0) == 0 || data_file.find(' ') != std::string::npos) return;
    file = data_file;
    if (file.is_relative()) file = std::filesystem::path(path).parent_path() / file;
  } else if (header_ended) {
    const std::streamoff header = in.tellg();
    start = header < 0 ? 0 : std::size_t(header);
  } else {
    throw InputError(path + ": NRRD header without data (no blank line before it)");
  }
  const std::size_t file_size = std::filesystem::file_size(file, ec);
  if (ec) throw InputError(path + ": its data file " + file.string() + " is missing");
  // Byte skip counts raw bytes (for compressed data, bytes after inflating: ignored here).
  if (byte_skip > 0 && encoding == "raw") start += std::size_t(byte_skip);
  const std::size_t present = file_size > start ? file_size - start : 0;
  std::size_t have = present, needed = data_bytes;
  if (encoding == "gzip" || encoding == "gz") {
    have = inflated_size(file.string(), start, data_bytes);
  } else if (encoding == "ascii" || encoding == "text" || encoding == "txt") {
    needed = 2 * values - 1;  // a digit per value and a separator between them, at least
  } else if (encoding == "hex") {
    needed = 2 * data_bytes;
  } else if (encoding == "bzip2" || encoding == "bz2" || encoding == "zrl") {
    return;  // no bound on what these expand to: teem judges
  }
  // Anything else is raw, or an encoding teem refuses before it allocates.
  if (have < needed) {
    throw InputError(path + ": truncated (" + std::to_string(have) + " of " +
                     std::to_string(needed) + " bytes of " + encoding + " voxel data)");
  }
}

template <class ImageT>
Image to_image(const ImageT& itk_image, const std::string& pixel_type, const std::string& path) {
  Image image;
  image.pixel_type = pixel_type;
  image.integer_valued = is_integer_pixel_type(pixel_type);
  Grid grid;
  const auto size = itk_image.GetLargestPossibleRegion().GetSize();
  for (int a = 0; a < 3; ++a) {
    grid.dims[a] = int(size[a]);
    grid.spacing[a] = itk_image.GetSpacing()[a];
    grid.origin[a] = itk_image.GetOrigin()[a];
    for (int c = 0; c < 3; ++c) grid.direction[a * 3 + c] = itk_image.GetDirection()[a][c];
  }
  image.voxels.grid = grid;
  resize_large(image.voxels.data, grid.voxel_count());
  constexpr bool is_float = std::is_same_v<typename ImageT::PixelType, float>;
  convert_to_float(itk_image.GetBufferPointer(), is_float ? "float32" : "float64",
                   grid.voxel_count(), image.voxels.data.data(), image.integer_valued, path);
  return image;
}

// Bytes needed: our float copy, ITK's output image of TPixel, and ITK's buffer of the file's
// own type when it differs (ITK converts from it).
template <class TPixel>
std::size_t read_bytes(std::size_t voxels, const itk::ImageIOBase& io) {
  const bool same = io.GetComponentType() == itk::ImageIOBase::MapPixelType<TPixel>::CType;
  return voxels * (sizeof(float) + sizeof(TPixel) + (same ? 0 : io.GetComponentSize()));
}

// Runs `read` (a file or series reader returning itk::Image<TPixel, 3>::Pointer) once the
// memory check passes, and turns ITK's failures into one-line InputErrors.
template <class TPixel, class Read>
Image read_as(const std::string& path, const itk::ImageIOBase& io, std::size_t voxels,
              const ReadOptions& options, Read read) {
  require_memory(read_bytes<TPixel>(voxels, io), options.max_bytes, path);
  try {
    typename itk::Image<TPixel, 3>::Pointer output = read();
    return to_image(*output, pixel_type_name(io), path);
  } catch (const itk::ExceptionObject& e) {
    throw InputError(path + ": cannot read (truncated or corrupt?): " + describe(e));
  } catch (const std::bad_alloc&) {
    throw InputError(path + ": not enough memory to read it");
  }
}

// Reads 8/16-bit integers and float32 as float (exact); wider types as double so that 32-bit
// labels are checked against 2^24 before they are narrowed.
template <class ReadWith>
Image read_dispatch(const itk::ImageIOBase& io, const std::string& path, ReadWith read_with) {
  const std::string type = pixel_type_name(io);
  if (type.empty())
    throw InputError(path + ": unsupported pixel type " +
                     itk::ImageIOBase::GetComponentTypeAsString(io.GetComponentType()));
  const bool narrow =
      type == "uint8" || type == "int8" || type == "uint16" || type == "int16" || type == "float32";
  return narrow ? read_with(float{}) : read_with(double{});
}

template <class TPixel>
void write_as(const Image& image, const std::string& path) {
  using ImageT = itk::Image<TPixel, 3>;
  const Grid& g = image.grid();
  auto itk_image = ImageT::New();
  typename ImageT::SizeType size;
  typename ImageT::SpacingType spacing;
  typename ImageT::PointType origin;
  typename ImageT::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    size[a] = itk::SizeValueType(g.dims[a]);
    spacing[a] = g.spacing[a];
    origin[a] = g.origin[a];
    for (int c = 0; c < 3; ++c) direction[a][c] = g.direction[a * 3 + c];
  }
  itk_image->SetRegions(typename ImageT::RegionType(size));
  itk_image->SetSpacing(spacing);
  itk_image->SetOrigin(origin);
  itk_image->SetDirection(direction);
  itk_image->Allocate();
  TPixel* out = itk_image->GetBufferPointer();
  const auto& data = image.voxels.data;
  for (std::size_t i = 0; i < data.size(); ++i) {
    // Values were range-checked by checked_write_pixel_type; integers are rounded.
    if constexpr (std::is_integral_v<TPixel>)
      out[i] = TPixel(std::llrint(data[i]));
    else
      out[i] = TPixel(data[i]);
  }
  auto writer = itk::ImageFileWriter<ImageT>::New();
  writer->SetFileName(path);
  writer->SetInput(itk_image);
  // Compress inside single-file formats; .mhd/.nhdr keep a raw data file for direct access.
  const std::string ext = image_extension(path);
  writer->SetUseCompression(ext == "nii.gz" || ext == "nrrd" || ext == "mha");
  writer->Update();
}

}  // namespace

Image read_image_itk(const std::string& path, const ReadOptions& options) {
  register_itk_factories();
  const std::string ext = image_extension(path);
  if (ext == "nii" || ext == "nii.gz") require_finite_nifti_geometry(path);
  if (ext == "mha" || ext == "mhd") require_sane_metaimage_header(path);
  if (ext == "nrrd" || ext == "nhdr") require_sane_nrrd_header(path);
  // The reader named by the extension only: ITK's factory would hand a file its own reader
  // refuses to the next one that accepts it, GDCM included, which then parses a damaged
  // .mha as DICOM.
  itk::ImageIOBase::Pointer io;
  if (ext == "nii" || ext == "nii.gz") io = itk::NiftiImageIO::New();
  if (ext == "nrrd" || ext == "nhdr") io = itk::NrrdImageIO::New();
  if (ext == "mha" || ext == "mhd") io = itk::MetaImageIO::New();
  bool readable = false;
  try {
    readable = io && io->CanReadFile(path.c_str());
  } catch (const itk::ExceptionObject&) {
  }
  if (!readable)
    throw InputError(path + ": not a valid ." + ext + " file (cannot read its header)");
  io->SetFileName(path);
  try {
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw InputError(path + ": cannot read its header: " + describe(e));
  }
  // ITK throws from GetComponentSize() on a type it could not name (MetaImage's MET_NONE).
  if (io->GetComponentType() == itk::IOComponentEnum::UNKNOWNCOMPONENTTYPE)
    throw InputError(path + ": unsupported or missing pixel type");
  const std::size_t voxels = checked_voxel_count(checked_3d_dims(*io, path), path);
  const std::size_t data_bytes = voxels * io->GetComponentSize();
  if (ext == "nii" || ext == "nii.gz") require_complete_nifti(path, data_bytes);
  if (ext == "mha" || ext == "mhd") require_complete_metaimage(path, data_bytes);
  if (ext == "nrrd" || ext == "nhdr") require_complete_nrrd(path, data_bytes, voxels);
  Image image = read_dispatch(*io, path, [&](auto pixel) {
    using TPixel = decltype(pixel);
    return read_as<TPixel>(path, *io, voxels, options, [&] {
      auto reader = itk::ImageFileReader<itk::Image<TPixel, 3>>::New();
      reader->SetFileName(path);
      reader->SetImageIO(io);
      reader->Update();
      return typename itk::Image<TPixel, 3>::Pointer(reader->GetOutput());
    });
  });
  if (ext == "nii" || ext == "nii.gz") place_in_nifti_frame(image, path, options.nifti_frame);
  return image;
}

Image read_dicom_series_itk(const std::string& folder, const ReadOptions& options) {
  register_itk_factories();
  std::vector<std::string> files;
  try {
    auto names = itk::GDCMSeriesFileNames::New();
    names->SetUseSeriesDetails(true);
    names->SetDirectory(folder);
    const auto& series = names->GetSeriesUIDs();
    if (!series.empty()) files = names->GetFileNames(series.front());
  } catch (const itk::ExceptionObject& e) {
    throw InputError(folder + ": cannot scan for DICOM files: " + describe(e));
  }
  if (files.empty()) {
    throw InputError(folder +
                     ": folder holds no DICOM series and no .tif/.tiff/.png slices to read");
  }
  auto io = itk::GDCMImageIO::New();
  io->SetFileName(files.front());
  try {
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw InputError(files.front() + ": cannot read DICOM header: " + describe(e));
  }
  if (io->GetNumberOfComponents() != 1) {
    throw InputError(folder + ": DICOM series has " + std::to_string(io->GetNumberOfComponents()) +
                     " components per voxel (RGB?); cvtmesh needs a scalar 3D image");
  }
  // One file per slice, unless a single multi-frame file holds the whole volume.
  unsigned long long nz = files.size();
  if (nz == 1 && io->GetNumberOfDimensions() >= 3) nz = io->GetDimensions(2);
  if (nz < 2)
    throw InputError(folder + ": DICOM series is 2D (one slice); cvtmesh needs a 3D image");
  const std::size_t voxels =
      checked_voxel_count({io->GetDimensions(0), io->GetDimensions(1), nz}, folder);
  return read_dispatch(*io, folder, [&](auto pixel) {
    using TPixel = decltype(pixel);
    return read_as<TPixel>(folder, *io, voxels, options, [&] {
      auto reader = itk::ImageSeriesReader<itk::Image<TPixel, 3>>::New();
      reader->SetImageIO(io);
      reader->SetFileNames(files);
      reader->Update();
      return typename itk::Image<TPixel, 3>::Pointer(reader->GetOutput());
    });
  });
}

void write_image_itk(const Image& image, const std::string& path) {
  register_itk_factories();
  const std::string type = checked_write_pixel_type(image, path);
  try {
    if (type == "uint8")
      write_as<std::uint8_t>(image, path);
    else if (type == "int8")
      write_as<std::int8_t>(image, path);
    else if (type == "uint16")
      write_as<std::uint16_t>(image, path);
    else if (type == "int16")
      write_as<std::int16_t>(image, path);
    else if (type == "uint32")
      write_as<std::uint32_t>(image, path);
    else if (type == "int32")
      write_as<std::int32_t>(image, path);
    else if (type == "float64")
      write_as<double>(image, path);
    else
      write_as<float>(image, path);
  } catch (const itk::ExceptionObject& e) {
    throw InputError("cannot write " + path + ": " + describe(e));
  } catch (const std::bad_alloc&) {
    throw InputError("cannot write " + path + ": not enough memory");
  }
}

}  // namespace cvt
