// `cvtmesh info IMAGE [--json]`: geometry, value range and label histogram of an image.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "io/image_io.h"

namespace cvt::cli {
namespace {

struct InfoArgs {
  std::string image;
  bool json = false;
  std::vector<double> slice_spacing;
};

// NaN/Inf voxels (grey images from some tools): reported apart, `mesh` refuses them.
std::size_t non_finite_count(const Image& img) {
  std::size_t n = 0;
  for (float v : img.voxels.data) n += !std::isfinite(v);
  return n;
}

nlohmann::json info_json(const Image& img) {
  const Grid& g = img.grid();
  const ValueRange range = value_range(img);
  nlohmann::json j;
  j["file"] = img.source;
  j["dims"] = {g.dims[0], g.dims[1], g.dims[2]};
  j["spacing"] = {g.spacing.x, g.spacing.y, g.spacing.z};
  j["origin"] = {g.origin.x, g.origin.y, g.origin.z};
  j["direction"] = g.direction;
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
  cmd->callback([args] {
    ReadOptions options;
    if (args->slice_spacing.size() == 3)
      options.slice_spacing_mm = {args->slice_spacing[0], args->slice_spacing[1], args->slice_spacing[2]};
    const Image img = read_image(args->image, options);
    if (args->json)
      std::cout << info_json(img).dump(2) << "\n";
    else
      print_text(img);
  });
}

}  // namespace cvt::cli
