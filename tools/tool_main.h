// The research programs' command-line glue (tools/): options parsed by CLI11, one error prefix
// ("<program>: error: <what>") and the exit codes of `insid` (README "exit codes";
// cli/commands.h): 0 done (also --help), 1 the run failed, 2 the command line was refused
// before any work (every CLI11 parse error, and a value read later through cli::parse_option).
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <exception>
#include <iostream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli/commands.h"
#include "optimizers/registry.h"

namespace insid::tools {

/// The footer of every program's --help.
inline constexpr const char* kExitCodeHelp =
    "Exit codes:\n"
    "  0  done (also --help)\n"
    "  1  the run failed: an unreadable or invalid file, an output that cannot be written\n"
    "  2  the command line was refused before any work: unknown option, a value of the wrong\n"
    "     form or out of range (every parse error of the CLI11 library is reported as 2)\n";

/// A finite number (CLI11 itself converts "nan" and "inf").
inline CLI::Validator finite_number() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        double value = 0.0;
        const char* end = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), end, value);
        if (ec != std::errc() || ptr != end || !std::isfinite(value))
          return "expected a finite number, got '" + text + "'";
        return "";
      },
      "NUMBER");
}

/// Throws std::invalid_argument naming the registry's algorithms when `name` is not one of them
/// (call it through cli::parse_option to make it a usage error).
inline void check_algorithm(const std::string& name) {
  const std::vector<std::string> known = opt::algorithm_names();
  if (std::find(known.begin(), known.end(), name) != known.end()) return;
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  throw std::invalid_argument("unknown algorithm '" + name + "'; the algorithms are " + list);
}

/// Thrown by parse() after --help was printed: the program exits with `code` (0).
struct HelpShown {
  int code = cli::kExitOk;
};

/// Parses the command line into `app` (adding the exit-code footer to its --help). --help
/// prints the help and throws HelpShown; a CLI11 parse error (unknown option, bad value)
/// throws cli::UsageError with CLI11's message, which names the option.
inline void parse(CLI::App& app, int argc, char** argv) {
  app.footer(kExitCodeHelp);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) throw HelpShown{app.exit(e)};  // --help
    throw cli::UsageError(e.what());
  }
}

/// Runs a program's body (which calls parse() first) and returns its exit code: the body's,
/// 0 after --help, 2 for a cli::UsageError ("<name>: error: <what>" and where the options
/// are), 1 for any other exception ("<name>: error: <what>").
template <class Body>
int run(const std::string& name, Body&& body) {
  try {
    return body();
  } catch (const HelpShown& h) {
    return h.code;
  } catch (const cli::UsageError& e) {
    std::cerr << name << ": error: " << e.what() << "\nRun '" << name
              << " --help' for the options.\n";
    return cli::kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << name << ": error: " << e.what() << '\n';
    return cli::kExitFailure;
  }
}

}  // namespace insid::tools
