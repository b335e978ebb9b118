// The subcommands of the cvtmesh CLI; each registers its options and its callback.
#pragma once

#include <CLI/CLI.hpp>
#include <iostream>

#include "base/image.h"

namespace cvt::cli {

// What reading the image warned about (NIfTI transforms that disagree), a stderr line each.
inline void print_image_warnings(const Image& image) {
  for (const std::string& warning : image.warnings)
    std::cerr << "cvtmesh: warning: " << warning << "\n";
}

void add_info_command(CLI::App& app);
void add_mesh_command(CLI::App& app);
void add_quality_command(CLI::App& app);

}  // namespace cvt::cli
