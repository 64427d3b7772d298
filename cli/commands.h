// Subcommands of the `insid` executable. Each adds itself to the CLI11 app; its callback
// does the work and throws std::exception on error (main prints "insid <command>: error: ..."
// and exits with kExitFailure, or kExitUsage for a UsageError).
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>

#include "identification/ins_problem.h"
#include "optimizers/parameters.h"

namespace insid::cli {

/// Exit codes of insid (README "Exit codes", and `insid --help`).
inline constexpr int kExitOk = 0;       ///< done (also --help, --version)
inline constexpr int kExitFailure = 1;  ///< the command ran and failed
inline constexpr int kExitUsage = 2;    ///< the command line was refused before any work
inline constexpr const char* kExitCodeHelp =
    "Exit codes:\n"
    "  0  done (also --help, --version)\n"
    "  1  the command ran and failed: unreadable or invalid data, config or result file, a\n"
    "     refused directory, a navigation that went non-finite, an I/O error\n"
    "  2  the command line was refused before any work: unknown command or option, missing\n"
    "     required option, a value of the wrong form or out of range, options that conflict\n"
    "     (every parse error of the CLI11 library, its codes 100-114, is reported as 2)\n"
    "Errors are printed as 'insid <command>: error: <what>' on stderr.\n";

/// A command line that parsed but cannot be run as given (exclusive options both given, a
/// needed one missing): exit code kExitUsage, like a parse error.
struct UsageError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// Runs `parse`, the reading of a command-line value (an --estimate form, a --shard, a preset
/// name), and reports a std::invalid_argument it throws as a UsageError (exit code 2), with
/// `option` named first when the message does not name it: a value the command line got wrong
/// is a usage error wherever in the command it is read. A message that starts with an option
/// ("--columns: ...") names it already; "" names none (the message says what was wrong).
template <class Parse>
auto parse_option(std::string_view option, Parse&& parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const UsageError&) {
    throw;
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    const bool named = what.rfind("--", 0) == 0 || what.find(option) != std::string::npos;
    throw UsageError(named ? what : std::string(option) + ": " + what);
  }
}

void add_navigate_command(CLI::App& app);
void add_identify_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_sweep_command(CLI::App& app);
void add_simulate_command(CLI::App& app);
void add_diagnose_command(CLI::App& app);
void add_merge_command(CLI::App& app);
void add_import_command(CLI::App& app);
void add_export_command(CLI::App& app);
void add_cross_imu_command(CLI::App& app);

}  // namespace insid::cli
