// Subcommands of the `insid` executable. Each adds itself to the CLI11 app; its callback
// does the work and throws std::exception on error (main prints it and exits with 1).
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "identification/ins_problem.h"
#include "optimizers/parameters.h"

namespace insid::cli {

void add_navigate_command(CLI::App& app);
void add_identify_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_sweep_command(CLI::App& app);
void add_simulate_command(CLI::App& app);
void add_diagnose_command(CLI::App& app);
void add_merge_command(CLI::App& app);
void add_import_command(CLI::App& app);
void add_export_command(CLI::App& app);

/// `--param KEY=VALUE` items; keys ending in _sigma are distances in sigma units, converted
/// to the normalised box of `mapping`, unless the algorithm has a parameter of that very name
/// (`own`, its opt::default_parameters: ekf-rts's initial_bias_sigma).
opt::ParameterMap parse_algorithm_params(const std::vector<std::string>& items,
                                         const ParameterMapping& mapping,
                                         const opt::ParameterList& own = {});

}  // namespace insid::cli
