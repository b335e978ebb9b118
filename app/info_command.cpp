// `cvtmesh info IMAGE [--json]`: geometry, value range and label histogram of an image.
#include <array>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "io/image_io.h"
#include "pipeline/parameter_registry.h"
#include "pipeline/run_report.h"

namespace cvt::cli {
namespace {

struct InfoArgs {
  std::string image;
  bool json = false;
  std::vector<double> slice_spacing;
  std::string nifti_frame;  // a word of the nifti_frame parameter; empty: its default
};

// NaN/Inf voxels (grey images from some tools): reported apart, `mesh` refuses them.
std::size_t non_finite_count(const Image& img) {
  std::size_t n = 0;
  for (float v : img.voxels.data) n += !std::isfinite(v);
  return n;
}

nlohmann::json info_json(const Image& img) {
  const ValueRange range = value_range(img);
  nlohmann::json j = image_json(img);
  j["pixel_type"] = img.pixel_type;
  j["integer_valued"] = img.integer_valued;
  j["range"] = {range.min, range.max};
  j["non_finite"] = non_finite_count(img);
  nlohmann::json hist = nlohmann::json::array();
  for (auto [label, count] : label_histogram(img)) hist.push_back({{"label", label}, {"count", count}});
  j["labels"] = hist;
  return j;
}

void print_text(const Image& img) {
  const Grid& g = img.grid();
  const ValueRange range = value_range(img);
  std::cout << std::setprecision(6);
  std::cout << "file:       " << img.source << "\n"
            << "dims:       " << g.dims[0] << " x " << g.dims[1] << " x " << g.dims[2] << "\n"
            << "spacing:    " << g.spacing.x << " " << g.spacing.y << " " << g.spacing.z << " mm\n"
            << "origin:     " << g.origin.x << " " << g.origin.y << " " << g.origin.z << " mm\n"
            << "direction:  ";
  for (int r = 0; r < 3; ++r)
    std::cout << (r ? " | " : "") << g.direction[3 * r] << " " << g.direction[3 * r + 1] << " "
              << g.direction[3 * r + 2];
  if (img.nifti)
    std::cout << "\nframe:      " << img.frame << " (NIfTI qform code " << img.nifti->qform.code
              << ", sform code " << img.nifti->sform.code << ")";
  std::cout << "\npixel type: " << img.pixel_type << (img.integer_valued ? " (labels)" : " (grey)")
            << "\nrange:      " << range.min << " .. " << range.max << "\n";
  if (const std::size_t n = non_finite_count(img))
    std::cout << "non-finite: " << n << (n == 1 ? " voxel" : " voxels") << " (NaN or Inf)\n";
  if (img.integer_valued) {
    std::cout << "labels:     label  voxels\n";
    for (auto [label, count] : label_histogram(img))
      std::cout << "            " << std::setw(5) << label << "  " << count << "\n";
  }
}

}  // namespace

void add_info_command(CLI::App& app) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = app.add_subcommand("info", "Print an image's geometry, value range and labels");
  cmd->add_option("IMAGE", args->image, "Image file or DICOM/slice folder")->required();
  cmd->add_flag("--json", args->json, "Print JSON instead of text");
  cmd->add_option("--slice-spacing", args->slice_spacing,
                  "Spacing (mm) x y z for a folder of 2D slices")
      ->expected(3);
  // The mesh command's option, from the parameter registry.
  const ParameterSpec& frame = *find_parameter("", "nifti_frame");
  const std::array<std::string, 2> frame_words{std::string(frame.words[0]),
                                               std::string(frame.words[1])};
  cmd->add_option("--" + std::string(frame.cli), args->nifti_frame, std::string(frame.tooltip))
      ->check(CLI::IsMember({frame_words[0], frame_words[1]}));
  cmd->callback([args, frame_words] {
    ReadOptions options;
    if (args->slice_spacing.size() == 3)
      options.slice_spacing_mm = {args->slice_spacing[0], args->slice_spacing[1], args->slice_spacing[2]};
    if (!args->nifti_frame.empty())
      options.nifti_frame = NiftiFrame(args->nifti_frame == frame_words[1]);
    const Image img = read_image(args->image, options);
    print_image_warnings(img);
    if (args->json)
      std::cout << info_json(img).dump(2) << "\n";
    else
      print_text(img);
  });
}

}  // namespace cvt::cli
