// The subcommands of the cvtmesh CLI; each registers its options and its callback.
#pragma once

#include <CLI/CLI.hpp>

namespace cvt::cli {

void add_info_command(CLI::App& app);

}  // namespace cvt::cli
