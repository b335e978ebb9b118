// Image IO: geometry and value round trips per format, slice folders, DICOM, the real liver,
// and one-line InputErrors for bad input.
#include <gtest/gtest.h>
#include <itkGDCMImageIO.h>
#include <itkImage.h>
#include <itkImageFileWriter.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>
#include <itkNiftiImageIO.h>
#include <itkVector.h>
#include <png.h>
#include <tiffio.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#include "base/errors.h"
#include "io/image_io.h"
#include "io/image_io_internal.h"

namespace fs = std::filesystem;
using cvt::Image;

namespace {

// A fresh folder under the system temp dir, removed with everything in it.
struct TempDir {
  fs::path path;
  TempDir() {
    static int counter = 0;
    path = fs::temp_directory_path() /
           ("cvtmesh-test-io-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// Rotation by `angle` about the unit axis (1,2,3)/√14 (Rodrigues), row-major.
std::array<double, 9> rotation(double angle) {
  const double n = std::sqrt(14.0), x = 1 / n, y = 2 / n, z = 3 / n;
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  return {t * x * x + c,     t * x * y - s * z, t * x * z + s * y, t * x * y + s * z, t * y * y + c,
          t * y * z - s * x, t * x * z - s * y, t * y * z + s * x, t * z * z + c};
}

Image make_image(const std::string& pixel_type, bool rotated) {
  Image im;
  im.pixel_type = pixel_type;
  im.integer_valued = pixel_type != "float32";
  cvt::Grid& g = im.voxels.grid;
  g.dims = {13, 11, 7};
  g.spacing = {0.7, 0.8, 1.3};
  g.origin = {-12.5, 30.25, 101.75};
  if (rotated) g.direction = rotation(0.4);
  im.voxels.data.resize(g.voxel_count());
  for (std::size_t n = 0; n < im.voxels.data.size(); ++n) {
    float v = float((n * 37) % 256);                                        // uint8
    if (pixel_type == "int16") v = float(int(n * 97 % 6001) - 3000);        // negative too
    if (pixel_type == "float32") v = float(std::sin(double(n)) * 123.456);  // non-integer
    im.voxels.data[n] = v;
  }
  return im;
}

void expect_same(const Image& a, const Image& b, double origin_tolerance = 1e-5) {
  EXPECT_EQ(a.grid().dims, b.grid().dims);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(a.grid().spacing[i], b.grid().spacing[i], 1e-5);
    EXPECT_NEAR(a.grid().origin[i], b.grid().origin[i], origin_tolerance);
  }
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(a.grid().direction[i], b.grid().direction[i], 1e-5);
  EXPECT_EQ(a.pixel_type, b.pixel_type);
  EXPECT_EQ(a.integer_valued, b.integer_valued);
  EXPECT_TRUE(a.voxels.data == b.voxels.data) << "voxel values differ";
}

// `f` must throw cvt::InputError whose single-line message names `path`.
void expect_input_error(const std::function<void()>& f, const std::string& path,
                        const std::string& also = "") {
  try {
    f();
    ADD_FAILURE() << "no InputError for " << path;
  } catch (const cvt::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    if (!also.empty()) EXPECT_NE(what.find(also), std::string::npos) << what;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got: " << e.what();
  }
}

void truncate_file(const std::string& path, double fraction) {
  fs::resize_file(path, std::uintmax_t(double(fs::file_size(path)) * fraction));
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// A single-channel slice of `values` (row by row) as a TIFF through libtiff: `bits` per sample
// of `format` (SAMPLEFORMAT_UINT, _INT, _IEEEFP for 16/32/64 bits); depths other than
// 8/16/32/64 bits packed most significant bit first, as TIFF stores them.
void write_tiff_slice(const std::string& file, int w, int h, int bits, int format,
                      const std::vector<double>& values, int samples = 1,
                      int photometric = PHOTOMETRIC_MINISBLACK) {
  TIFF* tiff = TIFFOpen(file.c_str(), "w");
  ASSERT_TRUE(tiff) << file;
  TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, w);
  TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, h);
  TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, bits);
  TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, samples);
  TIFFSetField(tiff, TIFFTAG_SAMPLEFORMAT, format);
  TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC, photometric);
  TIFFSetField(tiff, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tiff, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  TIFFSetField(tiff, TIFFTAG_ROWSPERSTRIP, 2);  // several strips, the last one short
  const int n = w * samples;
  std::vector<unsigned char> row((std::size_t(n) * bits + 7) / 8);
  for (int j = 0; j < h; ++j) {
    std::fill(row.begin(), row.end(), 0);
    for (int i = 0; i < n; ++i) {
      const double v = values[std::size_t(j) * n + i];
      unsigned char* at = row.data() + std::size_t(i) * bits / 8;
      if (format == SAMPLEFORMAT_IEEEFP && bits == 16) {  // half: v is exact, normal or 0
        const std::uint32_t f = std::bit_cast<std::uint32_t>(float(v));
        const std::uint16_t half =
            v == 0 ? 0
                   : std::uint16_t(((f >> 16) & 0x8000) | ((((f >> 23) & 0xff) - 112) << 10) |
                                   ((f >> 13) & 0x3ff));
        std::memcpy(at, &half, 2);
      } else if (format == SAMPLEFORMAT_IEEEFP && bits == 32) {
        const float f = float(v);
        std::memcpy(at, &f, 4);
      } else if (format == SAMPLEFORMAT_IEEEFP) {
        std::memcpy(at, &v, 8);
      } else if (bits == 8 || bits == 16 || bits == 32 || bits == 64) {
        const std::int64_t x = std::int64_t(v);  // two's complement: the low bytes
        std::memcpy(at, &x, std::size_t(bits / 8));
      } else {
        const std::uint64_t x = std::uint64_t(v);
        for (int b = 0; b < bits; ++b) {
          const std::size_t bit = std::size_t(i) * bits + b;
          if (x >> (bits - 1 - b) & 1) row[bit / 8] |= std::uint8_t(0x80 >> bit % 8);
        }
      }
    }
    ASSERT_EQ(TIFFWriteScanline(tiff, row.data(), std::uint32_t(j), 0), 1);
  }
  TIFFClose(tiff);
}

// A grey PNG slice of 8 or 16 bits through libpng (values stored as they are).
void write_png_slice(const std::string& file, int w, int h, int bits,
                     const std::vector<double>& values) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = png_uint_32(w);
  image.height = png_uint_32(h);
  // 16-bit "linear" grey is written unchanged (and tagged gamma 1).
  image.format = bits == 16 ? PNG_FORMAT_LINEAR_Y : PNG_FORMAT_GRAY;
  std::vector<std::uint16_t> wide(values.begin(), values.end());
  std::vector<std::uint8_t> narrow(values.begin(), values.end());
  const void* data = bits == 16 ? static_cast<const void*>(wide.data()) : narrow.data();
  ASSERT_TRUE(png_image_write_to_file(&image, file.c_str(), 0, data, 0, nullptr))
      << file << ": " << image.message;
}

}  // namespace

TEST(ImageIO, Extension) {
  EXPECT_EQ(cvt::image_extension("a/B.NII.GZ"), "nii.gz");
  EXPECT_EQ(cvt::image_extension("x.inr.gz"), "inr.gz");
  EXPECT_EQ(cvt::image_extension("dir.d/x.nrrd"), "nrrd");
  EXPECT_EQ(cvt::image_extension("dir.d/noext"), "");
}

TEST(ImageIO, RoundTripItkFormats) {
  TempDir dir;
  for (std::string ext : {"nii", "nii.gz", "nrrd", "mha", "mhd"}) {
    for (std::string type : {"uint8", "int16", "float32"}) {
      SCOPED_TRACE(ext + " " + type);
      const Image im = make_image(type, /*rotated=*/true);
      const std::string path = dir / ("im_" + type + "." + ext);
      cvt::write_image(im, path);
      const Image back = cvt::read_image(path);
      expect_same(im, back);
      EXPECT_EQ(back.source, path);
    }
  }
  EXPECT_TRUE(fs::exists(dir / "im_uint8.raw"));              // .mhd data file moved along
  for (const auto& entry : fs::directory_iterator(dir.path))  // no temp folder left behind
    EXPECT_EQ(entry.path().filename().string().find(".cvtmesh-tmp"), std::string::npos);
}

// What cvtmesh (ITK) writes has equal qform and sform: either frame reads ITK's geometry, bit
// for bit, without a warning. Other formats have no NIfTI frame.
TEST(ImageIO, NiftiFramesOfAnImageWeWrote) {
  TempDir dir;
  const Image im = make_image("uint8", /*rotated=*/true);
  for (std::string ext : {"nii", "nii.gz"}) {
    SCOPED_TRACE(ext);
    const std::string path = dir / ("im." + ext);
    cvt::write_image(im, path);
    cvt::ReadOptions qform;
    qform.nifti_frame = cvt::NiftiFrame::qform;
    const Image in_qform = cvt::read_image(path, qform), in_sform = cvt::read_image(path);
    EXPECT_TRUE(in_qform.grid().same_geometry(in_sform.grid(), 0.0));
    expect_same(im, in_sform);
    for (const Image* back : {&in_qform, &in_sform}) {
      ASSERT_TRUE(back->nifti.has_value());
      EXPECT_TRUE(back->nifti->qform.set() && back->nifti->sform.set());
      EXPECT_TRUE(back->warnings.empty());
    }
    EXPECT_EQ(in_qform.frame, "qform");
    EXPECT_EQ(in_sform.frame, "sform");
  }
  const std::string nrrd = dir / "im.nrrd";
  cvt::write_image(im, nrrd);
  const Image back = cvt::read_image(nrrd);
  EXPECT_FALSE(back.nifti.has_value());
  EXPECT_EQ(back.frame, "");
}

TEST(ImageIO, RoundTripInr) {
  TempDir dir;
  for (std::string ext : {"inr", "inr.gz"}) {
    for (std::string type : {"uint8", "int16", "float32"}) {
      SCOPED_TRACE(ext + " " + type);
      const Image im = make_image(type, /*rotated=*/false);
      const std::string path = dir / ("im_" + type + "." + ext);
      cvt::write_image(im, path);
      expect_same(im, cvt::read_image(path), 1e-4);  // INR keeps the origin as float
    }
  }
  const std::string rotated = dir / "rotated.inr";
  expect_input_error([&] { cvt::write_image(make_image("uint8", true), rotated); }, rotated,
                     "direction");
  EXPECT_FALSE(fs::exists(rotated));
}

TEST(ImageIO, FloatNaNIsReadNotRejected) {
  TempDir dir;
  Image im = make_image("float32", false);
  im.voxels.data[5] = std::nanf("");
  cvt::write_image(im, dir / "nan.nrrd");
  EXPECT_TRUE(std::isnan(cvt::read_image(dir / "nan.nrrd").voxels.data[5]));
  // niftilib replaces non-finite floats by 0 when reading; still no failure.
  cvt::write_image(im, dir / "nan.nii");
  EXPECT_EQ(cvt::read_image(dir / "nan.nii").voxels.data[5], 0.0f);
}

// The conversion runs in parallel chunks; it still converts every value and reports the first
// label a float cannot hold, as a serial scan would.
TEST(ImageIO, ConversionOfLargeBuffersReportsTheFirstBadLabel) {
  std::vector<std::int32_t> labels(1 << 20);
  for (std::size_t i = 0; i < labels.size(); ++i) labels[i] = std::int32_t(i % 1000);
  std::vector<float> out(labels.size(), -1.0f);
  using cvt::io_internal::convert_to_float;
  convert_to_float(labels.data(), "int32", labels.size(), out.data(), true, "x.nrrd");
  for (std::size_t i = 0; i < labels.size(); i += 997) ASSERT_EQ(out[i], float(i % 1000));
  labels[700001] = 16777218;
  labels[900001] = -33554432;
  try {
    convert_to_float(labels.data(), "int32", labels.size(), out.data(), true, "x.nrrd");
    ADD_FAILURE() << "a label beyond 2^24 was accepted";
  } catch (const cvt::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "x.nrrd: label 16777218 exceeds 2^24 in magnitude and cannot be stored exactly");
  }
}

TEST(ImageIO, SliceFolders) {
  TempDir dir;
  const int w = 9, h = 7, n = 11;
  auto value = [](int i, int j, int k) { return (i + 3 * j + 17 * k) % 200; };
  struct Case {
    std::string name, ext, type;  // the folder, the files' extension, the pixel type read
    int bits, format;             // the stored samples (format: TIFF only)
    std::function<double(int)> stored, read;  // value(i, j, k) → stored value, value read
  };
  auto same = [](int v) { return double(v); };
  // Depths other than 8/16/32 bits are scaled to the next one's range: 12-bit x → x·65535/4095.
  auto widen12 = [](int v) { return double(v * 20 * 65535 / 4095); };
  const int u = SAMPLEFORMAT_UINT, s = SAMPLEFORMAT_INT, f = SAMPLEFORMAT_IEEEFP;
  const std::vector<Case> cases = {
      {"png8", "png", "uint8", 8, u, same, same},
      {"png16", "png", "uint16", 16, u, [](int v) { return v * 300.0; },
       [](int v) { return v * 300.0; }},
      {"tif8", "tif", "uint8", 8, u, same, same},
      {"tifint8", "tif", "int8", 8, s, [](int v) { return v - 100.0; },
       [](int v) { return v - 100.0; }},
      {"tif16", "tif", "uint16", 16, u, [](int v) { return v * 300.0; },
       [](int v) { return v * 300.0; }},
      {"tifint16", "tif", "int16", 16, s, [](int v) { return (v - 100) * 300.0; },
       [](int v) { return (v - 100) * 300.0; }},
      // 32-bit labels below 2^24 (beyond it a float cannot hold them).
      {"tif32", "tif", "uint32", 32, u, [](int v) { return v * 70000.0; },
       [](int v) { return v * 70000.0; }},
      {"tifint32", "tif", "int32", 32, s, [](int v) { return (v - 100) * 70000.0; },
       [](int v) { return (v - 100) * 70000.0; }},
      {"tifhalf", "tif", "float16", 16, f, [](int v) { return v * 0.5 - 20; },
       [](int v) { return v * 0.5 - 20; }},
      {"tiffloat", "tiff", "float32", 32, f, [](int v) { return v * 0.25 - 20; },
       [](int v) { return v * 0.25 - 20; }},
      {"tifdouble", "tif", "float64", 64, f, [](int v) { return v * 0.125 - 20; },
       [](int v) { return v * 0.125 - 20; }},
      {"tif12", "tif", "uint16", 12, u, [](int v) { return v * 20.0; }, widen12},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path folder = dir.path / c.name;
    fs::create_directory(folder);
    // Unpadded numbers: s2 must come before s10.
    for (int k = 0; k < n; ++k) {
      std::vector<double> px(w * h);
      for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) px[j * w + i] = c.stored(value(i, j, k));
      const std::string file = (folder / ("s" + std::to_string(k + 1) + "." + c.ext)).string();
      if (c.ext == "png")
        write_png_slice(file, w, h, c.bits, px);
      else
        write_tiff_slice(file, w, h, c.bits, c.format, px);
    }
    write_bytes((folder / "notes.txt").string(), "ignored");
    cvt::ReadOptions options;
    options.slice_spacing_mm = {0.5, 0.6, 2.5};
    const Image im = cvt::read_image(folder.string(), options);
    EXPECT_EQ(im.grid().dims, (std::array<int, 3>{w, h, n}));
    EXPECT_EQ(im.grid().spacing.x, 0.5);
    EXPECT_EQ(im.grid().spacing.y, 0.6);
    EXPECT_EQ(im.grid().spacing.z, 2.5);
    EXPECT_EQ(im.pixel_type, c.type);
    EXPECT_EQ(im.integer_valued, c.type.rfind("float", 0) != 0);
    EXPECT_EQ(im.source, folder.string());
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
          ASSERT_EQ(im.voxels.at(i, j, k), float(c.read(value(i, j, k))))
              << i << " " << j << " " << k;
  }
}

// Slices that cannot make a volume: one-line InputErrors naming the file at fault.
TEST(ImageIO, BadSliceFolders) {
  TempDir dir;
  const std::vector<double> grey(6 * 4, 7.0);
  auto folder = [&](const std::string& name) {
    fs::create_directory(dir.path / name);
    write_tiff_slice(dir / (name + "/a1.tif"), 6, 4, 16, SAMPLEFORMAT_UINT, grey);
    return dir / name;
  };
  auto read = [](const std::string& p) { return [p] { cvt::read_image(p); }; };

  const std::string size = folder("size");
  write_tiff_slice(size + "/a2.tif", 5, 4, 16, SAMPLEFORMAT_UINT, grey);
  expect_input_error(read(size), size + "/a2.tif",
                     "is 5x4 uint16 with 1 channel(s), unlike a1.tif");
  const std::string type = folder("type");
  write_png_slice(type + "/a2.png", 6, 4, 8, grey);
  expect_input_error(read(type), type + "/a2.png", "is 6x4 uint8");
  const std::string colour = folder("colour");
  write_tiff_slice(colour + "/a0.tif", 6, 4, 8, SAMPLEFORMAT_UINT,
                   std::vector<double>(6 * 4 * 3, 9.0), 3, PHOTOMETRIC_RGB);
  expect_input_error(read(colour), colour + "/a0.tif", "has 3 channels");
  const std::string wide = folder("wide");
  write_tiff_slice(wide + "/a0.tif", 6, 4, 64, SAMPLEFORMAT_INT, grey);
  expect_input_error(read(wide), wide + "/a0.tif", "unsupported pixel type int64");
  const std::string text = folder("text");
  write_bytes(text + "/a2.png", "not an image");
  expect_input_error(read(text), text + "/a2.png", "cannot read image");
  const std::string cut = folder("cut");
  std::vector<double> noise(64 * 64);
  for (std::size_t i = 0; i < noise.size(); ++i) noise[i] = double(i * 7919 % 65536);
  write_png_slice(cut + "/a0.png", 64, 64, 16, noise);
  write_png_slice(cut + "/a1.png", 64, 64, 16, noise);
  fs::remove(cut + "/a1.tif");
  truncate_file(cut + "/a1.png", 0.5);
  expect_input_error(read(cut), cut + "/a1.png", "cannot read pixels");
  const std::string cut_tiff = folder("cut_tiff");
  write_tiff_slice(cut_tiff + "/a2.tif", 6, 4, 16, SAMPLEFORMAT_UINT, grey);
  truncate_file(cut_tiff + "/a2.tif", 0.3);
  expect_input_error(read(cut_tiff), cut_tiff + "/a2.tif");
}

TEST(ImageIO, DicomSeries) {
  using Image3 = itk::Image<std::int16_t, 3>;
  using Image2 = itk::Image<std::int16_t, 2>;
  TempDir dir;
  const Image im = make_image("int16", /*rotated=*/true);
  const cvt::Grid& g = im.grid();
  auto itk_image = Image3::New();
  Image3::SizeType size = {{13, 11, 7}};
  itk_image->SetRegions(Image3::RegionType(size));
  Image3::SpacingType spacing;
  Image3::PointType origin;
  Image3::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    spacing[a] = g.spacing[a];
    origin[a] = g.origin[a];
    for (int c = 0; c < 3; ++c) direction[a][c] = g.direction[a * 3 + c];
  }
  itk_image->SetSpacing(spacing);
  itk_image->SetOrigin(origin);
  itk_image->SetDirection(direction);
  itk_image->Allocate();
  for (std::size_t i = 0; i < im.voxels.size(); ++i)
    itk_image->GetBufferPointer()[i] = std::int16_t(im.voxels.data[i]);
  // GDCM takes each slice's geometry from its dictionary, as a scanner would write it.
  std::vector<std::unique_ptr<itk::MetaDataDictionary>> owned;
  itk::ImageSeriesWriter<Image3, Image2>::DictionaryArrayType dictionaries;
  std::vector<std::string> files;
  const auto& d = g.direction;
  auto str = [](std::initializer_list<double> v) {
    std::ostringstream s;
    s.precision(10);
    for (double x : v) s << (s.tellp() ? "\\" : "") << x;
    return s.str();
  };
  for (int k = 0; k < g.dims[2]; ++k) {
    owned.push_back(std::make_unique<itk::MetaDataDictionary>());
    auto& dict = *owned.back();
    const cvt::Vec3 p = g.index_to_world({0, 0, double(k)});
    const std::string root = "1.2.826.0.1.3680043.2.1125.7777.";
    itk::EncapsulateMetaData<std::string>(dict, "0008|0060", "CT");
    itk::EncapsulateMetaData<std::string>(dict, "0028|0004", "MONOCHROME2");
    itk::EncapsulateMetaData<std::string>(dict, "0008|0016", "1.2.840.10008.5.1.4.1.1.2");
    itk::EncapsulateMetaData<std::string>(dict, "0020|000d", root + "1");
    itk::EncapsulateMetaData<std::string>(dict, "0020|000e", root + "2");
    itk::EncapsulateMetaData<std::string>(dict, "0008|0018", root + "3." + std::to_string(k + 1));
    itk::EncapsulateMetaData<std::string>(dict, "0020|0013", std::to_string(k + 1));
    itk::EncapsulateMetaData<std::string>(dict, "0020|0032", str({p.x, p.y, p.z}));
    itk::EncapsulateMetaData<std::string>(dict, "0020|0037",
                                          str({d[0], d[3], d[6], d[1], d[4], d[7]}));
    itk::EncapsulateMetaData<std::string>(dict, "0028|0030", str({g.spacing.y, g.spacing.x}));
    itk::EncapsulateMetaData<std::string>(dict, "0018|0050", str({g.spacing.z}));
    dictionaries.push_back(&dict);
    files.push_back(dir / ("slice" + std::to_string(k + 1) + ".dcm"));
  }
  auto io = itk::GDCMImageIO::New();
  io->KeepOriginalUIDOn();
  auto writer = itk::ImageSeriesWriter<Image3, Image2>::New();
  writer->SetInput(itk_image);
  writer->SetImageIO(io);
  writer->SetFileNames(files);
  writer->SetMetaDataDictionaryArray(&dictionaries);
  ASSERT_NO_THROW(writer->Update());
  expect_same(im, cvt::read_image(dir.path.string()), 1e-4);
}

TEST(ImageIO, RealLiver) {
  const std::string path = CVTMESH_SOURCE_DIR "/data/liver.inr.gz";
  ASSERT_TRUE(fs::exists(path)) << path << " is missing: run scripts/fetch-data";
  const Image im = cvt::read_image(path);
  EXPECT_EQ(im.grid().dims, (std::array<int, 3>{438, 353, 165}));
  EXPECT_NEAR(im.grid().spacing.x, 0.617188, 1e-5);
  EXPECT_NEAR(im.grid().spacing.y, 0.617188, 1e-5);
  EXPECT_NEAR(im.grid().spacing.z, 1.33333, 1e-5);
  EXPECT_TRUE(im.integer_valued);
  const std::map<std::int64_t, std::size_t> expected = {
      {0, 22019024}, {255, 3160496}, {127, 314086}, {85, 17702}, {84, 2}};
  EXPECT_EQ(cvt::label_histogram(im), expected);
}

TEST(ImageIO, BadInputs) {
  TempDir dir;
  auto read = [](const std::string& p) { return [p] { cvt::read_image(p); }; };
  expect_input_error(read(dir / "missing.nii"), dir / "missing.nii", "no such file");
  write_bytes(dir / "a.xyz", "x");
  expect_input_error(read(dir / "a.xyz"), dir / "a.xyz", "unsupported image format '.xyz'");

  for (std::string name : {"cut.nii.gz", "cut.nii", "cut.nrrd", "cut.mha", "cut.nhdr"}) {
    cvt::write_image(make_image("float32", true), dir / name);
    truncate_file(dir / name, 0.5);
    expect_input_error(read(dir / name), dir / name);
  }
  cvt::write_image(make_image("float32", true), dir / "cut.mhd");
  truncate_file(dir / "cut.raw", 0.5);  // the data file beside the header
  expect_input_error(read(dir / "cut.mhd"), dir / "cut.mhd");
  cvt::write_image(make_image("float32", true), dir / "cut2.nhdr");
  truncate_file(dir / "cut2.raw", 0.5);
  expect_input_error(read(dir / "cut2.nhdr"), dir / "cut2.nhdr");

  std::mt19937 rng(1);
  std::string garbage(4000, '\0');
  for (char& c : garbage) c = char(rng());
  write_bytes(dir / "garbage.nii", garbage);
  expect_input_error(read(dir / "garbage.nii"), dir / "garbage.nii");
  write_bytes(dir / "garbage.inr.gz", garbage);
  expect_input_error(read(dir / "garbage.inr.gz"), dir / "garbage.inr.gz");

  for (std::string name : {"cut.inr.gz", "cut.inr"}) {
    cvt::write_image(make_image("int16", false), dir / name);
    truncate_file(dir / name, 0.5);
    expect_input_error(read(dir / name), dir / name);
  }
  const std::string liver = CVTMESH_SOURCE_DIR "/data/liver.inr.gz";
  if (fs::exists(liver)) {
    for (double fraction : {0.5, 0.99, 0.001}) {
      fs::copy_file(liver, dir / "liver.inr.gz", fs::copy_options::overwrite_existing);
      truncate_file(dir / "liver.inr.gz", fraction);
      expect_input_error(read(dir / "liver.inr.gz"), dir / "liver.inr.gz");
    }
  }

  // Headers announcing an empty or a huge image: refused before any voxel is read.
  auto inr_header = [](const std::string& dims) {
    std::string h = "#INRIMAGE-4#{\n" + dims + "VDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n";
    h += "CPU=decm\nVX=1\nVY=1\nVZ=1\n";
    return h + std::string(252 - h.size(), '\n') + "##}\n";
  };
  write_bytes(dir / "empty.inr", inr_header("XDIM=0\nYDIM=5\nZDIM=5\n"));
  expect_input_error(read(dir / "empty.inr"), dir / "empty.inr", "empty");
  write_bytes(dir / "huge.inr", inr_header("XDIM=100000\nYDIM=100000\nZDIM=100000\n"));
  expect_input_error(read(dir / "huge.inr"), dir / "huge.inr", "MB");

  // 2D, 4D and vector images.
  write_png_slice(dir / "slice.png", 4, 4, 8, std::vector<double>(16, 7));
  expect_input_error(read(dir / "slice.png"), dir / "slice.png", "is 2D");
  auto write_nii = [](auto itk_image, const std::string& path) {
    using ImageT = typename decltype(itk_image)::ObjectType;
    typename ImageT::SizeType size;
    size.Fill(4);
    itk_image->SetRegions(typename ImageT::RegionType(size));
    itk_image->Allocate(true);
    auto writer = itk::ImageFileWriter<ImageT>::New();
    writer->SetImageIO(itk::NiftiImageIO::New());
    writer->SetFileName(path);
    writer->SetInput(itk_image);
    writer->Update();
  };
  write_nii(itk::Image<std::uint8_t, 2>::New(), dir / "flat.nii");
  expect_input_error(read(dir / "flat.nii"), dir / "flat.nii", "is 2D");
  write_nii(itk::Image<float, 4>::New(), dir / "time.nii");
  expect_input_error(read(dir / "time.nii"), dir / "time.nii", "is 4D");
  write_nii(itk::Image<itk::Vector<float, 3>, 3>::New(), dir / "vector.nii");
  expect_input_error(read(dir / "vector.nii"), dir / "vector.nii", "components");

  // Folders with nothing to read.
  fs::create_directory(dir.path / "empty");
  expect_input_error(read(dir / "empty"), dir / "empty");
  fs::create_directory(dir.path / "text");
  write_bytes(dir / "text/readme.txt", "no images here");
  expect_input_error(read(dir / "text"), dir / "text");

  // Labels a float cannot hold, and a memory limit.
  Image big = make_image("uint8", false);
  big.pixel_type = "int32";
  big.voxels.data[3] = 16777218.0f;
  cvt::write_image(big, dir / "big.nrrd");
  expect_input_error(read(dir / "big.nrrd"), dir / "big.nrrd", "2^24");
  cvt::ReadOptions tiny;
  tiny.max_bytes = 1000;
  cvt::write_image(make_image("uint8", false), dir / "ok.inr");
  expect_input_error([&] { cvt::read_image(dir / "ok.inr", tiny); }, dir / "ok.inr", "MB");
  cvt::write_image(make_image("uint8", false), dir / "ok.mha");
  expect_input_error([&] { cvt::read_image(dir / "ok.mha", tiny); }, dir / "ok.mha", "MB");

  // Writing.
  const std::string nowhere = dir / "no/such/folder/out.nii";
  expect_input_error([&] { cvt::write_image(make_image("uint8", false), nowhere); }, nowhere,
                     "does not exist");
  const std::string wrong = dir / "out.jpg";
  expect_input_error([&] { cvt::write_image(make_image("uint8", false), wrong); }, wrong);
  Image overflow = make_image("uint8", false);
  overflow.voxels.data[0] = 300;
  expect_input_error([&] { cvt::write_image(overflow, dir / "o.nii"); }, dir / "o.nii", "uint8");
  EXPECT_FALSE(fs::exists(dir / "o.nii"));
}

// Headers that crashed or aborted inside ITK before cvtmesh refused them (found by the fuzz
// targets, tests/fuzz; their inputs replay in tests/fuzz/regressions).
TEST(ImageIO, CorruptHeadersFoundByFuzzing) {
  TempDir dir;
  auto read = [](const std::string& p) { return [p] { cvt::read_image(p); }; };
  // NIfTI-1: a float field patched at its byte offset (ITK writes little-endian here).
  auto patched_nifti = [&](const std::string& name, std::size_t offset, float value) {
    cvt::write_image(make_image("uint8", false), dir / name);
    std::fstream f(dir / name, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff(offset));
    f.write(reinterpret_cast<const char*>(&value), sizeof value);
    return dir / name;
  };
  // A NaN in the sform made vnl_svd abort the process.
  const std::string nan_srow = patched_nifti("nan_srow.nii", 280, std::nanf(""));
  expect_input_error(read(nan_srow), nan_srow, "corrupt NIfTI header (srow");
  const std::string inf_pixdim = patched_nifti("inf_pixdim.nii", 80, INFINITY);
  expect_input_error(read(inf_pixdim), inf_pixdim, "corrupt NIfTI header (pixdim");
  // A vox_offset beyond any size was converted to size_t (undefined behaviour).
  const std::string far_data = patched_nifti("far_data.nii", 108, 1e30f);
  expect_input_error(read(far_data), far_data, "vox_offset");

  // MetaImage: MetaIO's fixed buffers, and a buffer sized from a failed stream.
  auto mha = [&](const std::string& name, const std::string& ndims, const std::string& extra) {
    write_bytes(dir / name, "ObjectType = Image\nNDims = " + ndims +
                                "\nDimSize = 2 2 2\nElementType = MET_UCHAR\n" + extra +
                                "ElementDataFile = LOCAL\n" + std::string(8, '\1'));
    return dir / name;
  };
  const std::string fine = mha("fine.mha", "3", "");
  EXPECT_EQ(cvt::read_image(fine).voxels.data, std::vector<float>(8, 1.0f));
  const std::string long_name = mha("long_name.mha", "3", std::string(300, 'A') + " = 1\n");
  expect_input_error(read(long_name), long_name, "header line 5");
  const std::string many_dims = mha("many_dims.mha", "100000", "");
  expect_input_error(read(many_dims), many_dims, "NDims");
  const std::string no_size = mha("no_size.mha", "3", "CompressedData = True\n");
  expect_input_error(read(no_size), no_size, "CompressedDataSize");
  const std::string bad_type = dir / "bad_type.mha";
  write_bytes(bad_type,
              "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\n"
              "ElementType = MET_BOGUS\nElementDataFile = LOCAL\n" +
                  std::string(8, '\1'));
  expect_input_error(read(bad_type), bad_type, "pixel type");
  // A numbered data file pattern is MetaIO's snprintf format: "%s" or "%L" crashed it.
  const std::string format = dir / "format.mha";
  write_bytes(format,
              "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
              "ElementDataFile = slice%s.raw 1 2 1\n");
  expect_input_error(read(format), format, "exactly one %d");

  const std::string zero_step = dir / "zero_step.mha";
  write_bytes(zero_step,
              "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\n"
              "ElementType = MET_UCHAR\nElementDataFile = slice%d.raw 1 2 0\n");
  expect_input_error(read(zero_step), zero_step, "step >= 1");

  // NIfTI without its magic (niftilib reads it as ANALYZE) announcing 1e9 voxels: refused
  // before niftilib allocates them.
  std::string analyze(352, '\0');
  const std::int32_t header_size = 348;
  const std::int16_t dims[4] = {3, 1000, 1000, 1000}, type[2] = {2, 8};
  std::memcpy(analyze.data(), &header_size, 4);
  std::memcpy(analyze.data() + 40, dims, sizeof dims);
  std::memcpy(analyze.data() + 70, type, sizeof type);
  write_bytes(dir / "analyze.nii", analyze + "0123456789");
  expect_input_error(read(dir / "analyze.nii"), dir / "analyze.nii", "truncated");

  // MetaIO corrupted its heap on a header that repeats a field (among other damage).
  const std::string twice = mha("twice.mha", "3", "NDims = 4\n");
  expect_input_error(read(twice), twice, "'NDims' given twice");
  // An empty ElementDataFile made MetaIO size a buffer from a failed stream (-1 bytes).
  const std::string no_file = dir / "no_file.mha";
  write_bytes(no_file,
              "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
              "ElementDataFile = \n");
  expect_input_error(read(no_file), no_file, "ElementDataFile is empty");
  // teem reads "raw\0junk" as raw: the data check must too (it skipped the file, then teem
  // allocated 7 GB).
  const std::string nul = dir / "nul.nrrd";
  write_bytes(nul,
              "NRRD0004\ntype: double\ndimension: 3\nsizes: 444444442 2 1\n"
              "endian: little\nencoding: raw" +
                  std::string(1, '\0') + "x\n\n" + std::string(8, '\1'));
  expect_input_error(read(nul), nul, "truncated");
  // teem smashed its stack on a header line of about 1000 characters.
  const std::string long_line = dir / "long_line.nrrd";
  write_bytes(long_line, "NRRD0004\ntype: " + std::string(1000, 'x') +
                             "\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n" +
                             std::string(8, '\1'));
  expect_input_error(read(long_line), long_line, "bad NRRD header line 2");

  // NRRD: teem allocated and zeroed what the header announces (here 4.8 GB) before reading.
  const std::string gigavoxels = dir / "gigavoxels.nrrd";
  write_bytes(gigavoxels,
              "NRRD0004\ntype: int\ndimension: 3\nsizes: 1 597950803 2\n"
              "endian: little\nencoding: raw\n\n" +
                  std::string(27, '\1'));
  expect_input_error(read(gigavoxels), gigavoxels, "truncated (27 of 4783606424 bytes");
  const std::string gz_claim = dir / "gz_claim.nrrd";
  write_bytes(gz_claim,
              "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1000 1000 1000\n"
              "encoding: gzip\n\n" +
                  std::string(30, '\0'));
  expect_input_error(read(gz_claim), gz_claim, "gzip voxel data");

  // INRIMAGE: CGAL reads no field after a '#' comment line, so neither do we (CPU, TYPE unset).
  const std::string commented = dir / "commented.inr";
  std::string inr =
      "#INRIMAGE-4#{\nXDIM=2\nYDIM=2\nZDIM=2\nVDIM=1\n#a comment\n"
      "TYPE=unsigned fixed\nPIXSIZE=8 bits\nCPU=decm\nVX=1\nVY=1\nVZ=1\n";
  inr += std::string(252 - inr.size(), '\n') + "##}\n" + std::string(8, '\1');
  write_bytes(commented, inr);
  expect_input_error(read(commented), commented, "lacks a known CPU");

  // Only the reader the extension names: an NRRD file called .mha is not a MetaImage.
  cvt::write_image(make_image("uint8", false), dir / "really.nrrd");
  fs::rename(dir / "really.nrrd", dir / "really.mha");
  expect_input_error(read(dir / "really.mha"), dir / "really.mha", "MetaImage header");
}
