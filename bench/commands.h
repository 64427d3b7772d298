// Subcommands of the `insid` executable. Each adds itself to the CLI11 app; its callback
// does the work and throws std::exception on error (main prints it and exits with 1).
#pragma once

#include <CLI/CLI.hpp>

namespace insid::cli {

void add_navigate_command(CLI::App& app);

}  // namespace insid::cli
