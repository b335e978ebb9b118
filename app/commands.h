// The subcommands of the cvtmesh CLI; each registers its options and its callback.
#pragma once

#include <CLI/CLI.hpp>

namespace cvt::cli {

void add_info_command(CLI::App& app);
void add_mesh_command(CLI::App& app);
void add_quality_command(CLI::App& app);

}  // namespace cvt::cli
