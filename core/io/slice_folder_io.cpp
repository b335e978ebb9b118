// A folder of 2D .tif/.tiff/.png slices read into one 3D image, with libtiff and libpng
// directly: ITK's TIFF reader knows only 8/16-bit integers and float32 (it read uint32 slices as
// zeros and half floats as their raw bits), and its PNG reader shifts values down by the sBIT
// chunk. Each file's format is told by its first bytes, not its extension.
#include <png.h>
#include <tiffio.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <csetjmp>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <vector>

#include "base/errors.h"
#include "base/memory.h"
#include "io/image_io.h"
#include "io/image_io_internal.h"

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

// What a slice file holds, from its header.
struct SliceInfo {
  std::size_t width = 0, height = 0;
  int channels = 1;
  bool volume = false;  // a 3D image (TIFF ImageDepth > 1)
  std::string type;     // our pixel type name ("uint8", ..., "float16"); "" when unsupported
  std::string stored;   // the stored sample type, named for the message when unsupported
};

// Bytes per value in the buffer a slice is read into: half floats are read as float32.
std::size_t read_size(const std::string& type) {
  if (type == "uint8" || type == "int8") return 1;
  if (type == "uint16" || type == "int16") return 2;
  if (type == "float64") return 8;
  return 4;  // uint32, int32, float16 (read as float32), float32
}

// An open slice file: its header read, its pixels read on demand.
class SliceFile {
 public:
  virtual ~SliceFile() = default;
  // Reads the single-channel pixels, rows top first, as info.type (float16 as float32) into
  // `out` (width × height × read_size(info.type) bytes). Throws InputError naming the file.
  virtual void read(unsigned char* out) = 0;
  SliceInfo info;

 protected:
  explicit SliceFile(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void fail_pixels(const std::string& why) const {
    throw InputError(file_ + ": cannot read pixels (" + one_line(why) + ")");
  }
  std::string file_;
};

[[noreturn]] void fail_open(const std::string& file, const std::string& why) {
  throw InputError(file + ": cannot read image (" + one_line(why) + ")");
}

// --- PNG (libpng) --------------------------------------------------------------------------
// Read as OpenImageIO read them before: palettes expanded to RGB, 1/2/4-bit grey scaled to 8
// bits (1-bit 1 → 255), transparency to an alpha channel, 16-bit values native-endian; the
// sBIT chunk is ignored (values stay as stored).

struct PngErrors {
  std::string message;  // libpng's first error
};

void png_error_handler(png_structp png, png_const_charp message) {
  auto* errors = static_cast<PngErrors*>(png_get_error_ptr(png));
  if (errors && errors->message.empty() && message) errors->message = message;
  png_longjmp(png, 1);
}

void png_warning_handler(png_structp, png_const_charp) {}  // benign chunk problems

void png_read_file(png_structp png, png_bytep data, png_size_t length) {
  auto* file = static_cast<std::FILE*>(png_get_io_ptr(png));
  if (std::fread(data, 1, length, file) != length)
    png_error(png, std::ferror(file) ? "read error" : "file ends early (truncated?)");
}

// libpng reports errors by longjmp: these two keep the setjmp frames free of C++ objects.
bool png_read_header(png_structp png, png_infop info, std::FILE* file) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_read_fn(png, file, png_read_file);
  png_read_info(png, info);
  png_set_expand(png);
  if constexpr (std::endian::native == std::endian::little) png_set_swap(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  return true;
}

bool png_read_rows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_image(png, rows);
  png_read_end(png, info);
  return true;
}

class PngSlice final : public SliceFile {
 public:
  explicit PngSlice(const std::string& file) : SliceFile(file) {
    h_.file = std::fopen(file.c_str(), "rb");
    if (!h_.file) fail_open(file, std::strerror(errno));
    h_.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &errors_, png_error_handler,
                                    png_warning_handler);
    if (h_.png) h_.info = png_create_info_struct(h_.png);
    if (!h_.png || !h_.info) fail_open(file, "cannot start libpng");
    if (!png_read_header(h_.png, h_.info, h_.file)) fail_open(file, errors_.message);
    info.width = png_get_image_width(h_.png, h_.info);
    info.height = png_get_image_height(h_.png, h_.info);
    info.channels = png_get_channels(h_.png, h_.info);
    info.type = png_get_bit_depth(h_.png, h_.info) == 16 ? "uint16" : "uint8";
    info.stored = info.type;
  }

  void read(unsigned char* out) override {
    const std::size_t row_bytes = info.width * read_size(info.type);
    if (png_get_rowbytes(h_.png, h_.info) != row_bytes) fail_pixels("unexpected row size");
    std::vector<png_bytep> rows(info.height);
    for (std::size_t j = 0; j < info.height; ++j) rows[j] = out + j * row_bytes;
    if (!png_read_rows(h_.png, h_.info, rows.data())) fail_pixels(errors_.message);
  }

 private:
  struct Handles {  // released also when the constructor throws
    std::FILE* file = nullptr;
    png_structp png = nullptr;
    png_infop info = nullptr;
    ~Handles() {
      if (png) png_destroy_read_struct(&png, &info, nullptr);
      if (file) std::fclose(file);
    }
  };
  PngErrors errors_;  // declared first: libpng holds a pointer to it until h_ goes
  Handles h_;
};

// --- TIFF (libtiff) ------------------------------------------------------------------------
// The first image of the file (later pages are not read). Integers of 8/16/32 bits and floats
// of 16/32/64 bits are kept as stored; other unsigned depths are scaled to the full range of
// the next of 8/16/32 bits (4-bit 1 → 17, 12-bit 4095 → 65535), and min-is-white unsigned
// slices of 8 bits or fewer are inverted: both as OpenImageIO read them (wider ones are not
// inverted).

int tiff_message_handler(TIFF* tiff, void* user_data, const char*, const char* format,
                         va_list args) {
  auto* message = static_cast<std::string*>(user_data);
  if (message && message->empty()) {
    char text[512];
    std::vsnprintf(text, sizeof text, format, args);
    *message = text;
    // Many messages start with the file name, which our message names already.
    const std::string prefix = tiff ? std::string(TIFFFileName(tiff)) + ": " : "";
    if (!prefix.empty() && message->rfind(prefix, 0) == 0) message->erase(0, prefix.size());
  }
  return 1;  // handled: nothing on stderr
}

float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = std::uint32_t(h & 0x8000) << 16;
  std::uint32_t exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  std::uint32_t bits;
  if (exponent == 0x1f) {
    bits = sign | 0x7f800000 | (mantissa << 13);  // infinity, NaN
  } else if (exponent != 0) {
    bits = sign | ((exponent + 112) << 23) | (mantissa << 13);
  } else if (mantissa == 0) {
    bits = sign;  // ±0
  } else {        // subnormal: normalise
    exponent = 113;
    while (!(mantissa & 0x400)) mantissa <<= 1, --exponent;
    bits = sign | (exponent << 23) | ((mantissa & 0x3ff) << 13);
  }
  return std::bit_cast<float>(bits);
}

// `value` of `from` bits scaled to the range of `to` bits, rounded down.
std::uint32_t widen_bits(std::uint32_t value, int from, int to) {
  return std::uint32_t(std::uint64_t(value) * ((std::uint64_t(1) << to) - 1) /
                       ((std::uint64_t(1) << from) - 1));
}

class TiffSlice final : public SliceFile {
 public:
  explicit TiffSlice(const std::string& file) : SliceFile(file) {
    std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> options(TIFFOpenOptionsAlloc(),
                                                                         TIFFOpenOptionsFree);
    if (!options) fail_open(file, "cannot start libtiff");
    // Handlers per file, with its own message string: no stderr, and no global state.
    TIFFOpenOptionsSetErrorHandlerExtR(options.get(), tiff_message_handler, &error_);
    TIFFOpenOptionsSetWarningHandlerExtR(options.get(), tiff_message_handler, nullptr);
    tiff_.reset(TIFFOpenExt(file.c_str(), "rm", options.get()));  // m: read(), no memory map
    if (!tiff_) fail_open(file, error_.empty() ? "not a valid TIFF file" : error_);
    std::uint32_t width = 0, height = 0, depth = 1;
    std::uint16_t samples = 1, format = SAMPLEFORMAT_UINT, photometric = PHOTOMETRIC_MINISBLACK;
    TIFFGetField(tiff_.get(), TIFFTAG_IMAGEWIDTH, &width);
    TIFFGetField(tiff_.get(), TIFFTAG_IMAGELENGTH, &height);
    TIFFGetFieldDefaulted(tiff_.get(), TIFFTAG_IMAGEDEPTH, &depth);
    TIFFGetFieldDefaulted(tiff_.get(), TIFFTAG_BITSPERSAMPLE, &bits_);
    TIFFGetFieldDefaulted(tiff_.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
    TIFFGetFieldDefaulted(tiff_.get(), TIFFTAG_SAMPLEFORMAT, &format);
    TIFFGetField(tiff_.get(), TIFFTAG_PHOTOMETRIC, &photometric);
    info.width = width;
    info.height = height;
    info.volume = depth > 1;
    info.channels = photometric == PHOTOMETRIC_PALETTE ? 3 : samples;  // palettes read as RGB
    const std::string bits = std::to_string(bits_);
    if (format == SAMPLEFORMAT_IEEEFP) {
      info.stored = "float" + bits;
      if (bits_ == 16 || bits_ == 32 || bits_ == 64) info.type = info.stored;
    } else if (format == SAMPLEFORMAT_INT) {
      info.stored = "int" + bits;
      if (bits_ == 8 || bits_ == 16 || bits_ == 32) info.type = info.stored;
    } else if (format == SAMPLEFORMAT_UINT || format == SAMPLEFORMAT_VOID) {
      info.stored = "uint" + bits;
      if (bits_ >= 1 && bits_ <= 32)
        info.type = bits_ <= 8 ? "uint8" : bits_ <= 16 ? "uint16" : "uint32";
    } else {
      info.stored = "complex" + bits;
    }
    invert_ = photometric == PHOTOMETRIC_MINISWHITE && info.type == "uint8";
  }

  void read(unsigned char* out) override {
    const std::size_t w = info.width, h = info.height;
    const std::size_t row_bytes = (w * bits_ + 7) / 8;  // one sample per pixel, rows padded
    if (std::size_t(TIFFScanlineSize64(tiff_.get())) != row_bytes)
      fail_pixels("unexpected row size");
    const int container = int(read_size(info.type)) * 8;
    // Stored values of the read type land in `out` directly; others are converted from `raw`.
    const bool direct = bits_ == container && info.type != "float16";
    std::vector<unsigned char> raw(direct ? 0 : row_bytes * h);
    unsigned char* data = direct ? out : raw.data();
    if (TIFFIsTiled(tiff_.get()))
      read_tiles(data, row_bytes);
    else
      read_strips(data, row_bytes);
    if (info.type == "float16") {
      for (std::size_t i = 0; i < w * h; ++i) {
        std::uint16_t half;
        std::memcpy(&half, data + 2 * i, 2);
        const float value = half_to_float(half);
        std::memcpy(out + 4 * i, &value, 4);
      }
    } else if (!direct) {  // 1..31 bits, MSB first within each padded row
      for (std::size_t j = 0; j < h; ++j) {
        const unsigned char* row = data + j * row_bytes;
        for (std::size_t i = 0; i < w; ++i) {
          std::uint32_t value = 0;
          for (std::size_t bit = i * bits_, end = bit + bits_; bit < end; ++bit)
            value = value << 1 | ((row[bit / 8] >> (7 - bit % 8)) & 1);
          value = widen_bits(value, bits_, container);
          unsigned char* dst = out + (j * w + i) * std::size_t(container / 8);
          if (container == 8) *dst = std::uint8_t(value);
          if (container == 16) {
            const std::uint16_t v16 = std::uint16_t(value);
            std::memcpy(dst, &v16, 2);
          }
          if (container == 32) std::memcpy(dst, &value, 4);
        }
      }
    }
    if (invert_)
      for (std::size_t i = 0; i < w * h; ++i) out[i] = std::uint8_t(255 - out[i]);
  }

 private:
  std::string error_message() const { return error_.empty() ? "corrupt image data" : error_; }

  void read_strips(unsigned char* data, std::size_t row_bytes) {
    std::uint32_t rows_per_strip = 0;
    TIFFGetFieldDefaulted(tiff_.get(), TIFFTAG_ROWSPERSTRIP, &rows_per_strip);
    const std::size_t h = info.height;
    const std::size_t step = rows_per_strip == 0 || rows_per_strip > h ? h : rows_per_strip;
    for (std::size_t row = 0; row < h; row += step) {
      const tmsize_t bytes = tmsize_t(std::min(step, h - row) * row_bytes);
      const tstrip_t strip = TIFFComputeStrip(tiff_.get(), std::uint32_t(row), 0);
      if (TIFFReadEncodedStrip(tiff_.get(), strip, data + row * row_bytes, bytes) != bytes)
        fail_pixels(error_message());
    }
  }

  void read_tiles(unsigned char* data, std::size_t row_bytes) {
    std::uint32_t tile_w = 0, tile_h = 0;
    TIFFGetField(tiff_.get(), TIFFTAG_TILEWIDTH, &tile_w);
    TIFFGetField(tiff_.get(), TIFFTAG_TILELENGTH, &tile_h);
    const std::size_t w = info.width, h = info.height;
    const std::size_t tile_row_bytes = (std::size_t(tile_w) * bits_ + 7) / 8;
    const std::uint64_t tile_bytes = std::uint64_t(TIFFTileSize64(tiff_.get()));
    // Tiles start on whole bytes of a row; and a tile far larger than the slice is a corrupt
    // header, not a reason to allocate gigabytes.
    if (tile_w == 0 || tile_h == 0 || (std::uint64_t(tile_w) * bits_) % 8 != 0 ||
        tile_bytes != std::uint64_t(tile_row_bytes) * tile_h ||
        tile_bytes > row_bytes * h + (std::uint64_t(1) << 26))
      fail_pixels("bad tile size " + std::to_string(tile_w) + "x" + std::to_string(tile_h));
    std::vector<unsigned char> tile(tile_bytes);
    for (std::size_t y = 0; y < h; y += tile_h) {
      for (std::size_t x = 0; x < w; x += tile_w) {
        if (TIFFReadTile(tiff_.get(), tile.data(), std::uint32_t(x), std::uint32_t(y), 0, 0) < 0)
          fail_pixels(error_message());
        const std::size_t rows = std::min<std::size_t>(tile_h, h - y);
        const std::size_t bytes = (std::min<std::size_t>(tile_w, w - x) * bits_ + 7) / 8;
        for (std::size_t r = 0; r < rows; ++r)
          std::memcpy(data + (y + r) * row_bytes + x * bits_ / 8, tile.data() + r * tile_row_bytes,
                      bytes);
      }
    }
  }

  std::string error_;  // libtiff's first error on this file; declared before tiff_, which uses it
  std::unique_ptr<TIFF, void (*)(TIFF*)> tiff_{nullptr, TIFFClose};
  std::uint16_t bits_ = 1;
  bool invert_ = false;
};

// The slice reader for the file's content (PNG or TIFF signature).
std::unique_ptr<SliceFile> open_slice(const std::string& file) {
  unsigned char magic[8] = {};
  std::size_t got = 0;
  if (std::FILE* f = std::fopen(file.c_str(), "rb")) {
    got = std::fread(magic, 1, sizeof magic, f);
    std::fclose(f);
  } else {
    fail_open(file, std::strerror(errno));
  }
  if (got == 8 && png_sig_cmp(magic, 0, 8) == 0) return std::make_unique<PngSlice>(file);
  const bool intel = magic[0] == 'I' && magic[1] == 'I' && magic[3] == 0;
  const bool motorola = magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0;
  if (got >= 4 && ((intel && (magic[2] == 42 || magic[2] == 43)) ||
                   (motorola && (magic[3] == 42 || magic[3] == 43))))
    return std::make_unique<TiffSlice>(file);
  fail_open(file, got == 0 ? "empty file" : "not a PNG or TIFF file");
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
  const SliceInfo spec = open_slice(first)->info;
  if (spec.channels != 1) {
    throw InputError(first + ": has " + std::to_string(spec.channels) +
                     " channels (colour?); cvtmesh needs single-channel grey slices");
  }
  if (spec.volume) throw InputError(first + ": is a 3D image, not a 2D slice");
  const std::string pixel_type = spec.type;
  if (pixel_type.empty()) throw InputError(first + ": unsupported pixel type " + spec.stored);
  // Integers are read as stored (never scaled to 0..1); half floats as float32, which holds
  // every half value exactly.
  const std::string read_type = pixel_type == "float16" ? "float32" : pixel_type;

  const std::size_t nx = spec.width, ny = spec.height;
  const std::size_t voxels = checked_voxel_count({nx, ny, names.size()}, folder);
  const std::size_t slice_voxels = nx * ny;
  require_memory(voxels * sizeof(float) + slice_voxels * read_size(pixel_type), options.max_bytes,
                 folder);

  Image image;
  image.pixel_type = pixel_type;
  image.integer_valued = is_integer_pixel_type(pixel_type);
  Grid& g = image.voxels.grid;
  g.dims = {int(nx), int(ny), int(names.size())};
  g.spacing = s;
  resize_large(image.voxels.data, voxels);
  std::vector<unsigned char> buffer(slice_voxels * read_size(pixel_type));
  for (std::size_t k = 0; k < names.size(); ++k) {
    const std::string file = (fs::path(folder) / names[k]).string();
    auto input = open_slice(file);
    const SliceInfo& sk = input->info;
    if (sk.width != spec.width || sk.height != spec.height || sk.channels != spec.channels ||
        sk.type != spec.type || sk.volume != spec.volume) {
      throw InputError(file + ": is " + std::to_string(sk.width) + "x" + std::to_string(sk.height) +
                       " " + sk.type + " with " + std::to_string(sk.channels) +
                       " channel(s), unlike " + names[0] + " (" + std::to_string(spec.width) + "x" +
                       std::to_string(spec.height) + " " + pixel_type + ")");
    }
    input->read(buffer.data());
    convert_to_float(buffer.data(), read_type, slice_voxels,
                     image.voxels.data.data() + k * slice_voxels, image.integer_valued, file);
  }
  image.source = folder;
  return image;
}

}  // namespace cvt
