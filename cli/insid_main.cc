// insid: identify INS sensor errors from flight data and benchmark the optimizers that do it.
#include <exception>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench/campaign.h"
#include "cli/commands.h"
#include "identification/identify.h"
#include "kernel/cpu_path.h"

namespace {

// "insid", "insid bench", "insid import csv": the subcommands the parser reached.
std::string command_path(const CLI::App& app) {
  std::string path = "insid";
  const CLI::App* at = &app;
  for (;;) {
    const std::vector<CLI::App*> subs = at->get_subcommands();
    if (subs.empty()) return path;
    at = subs.front();
    path += " " + at->get_name();
  }
}

}  // namespace

int main(int argc, char** argv) {
  using insid::cli::kExitFailure;
  using insid::cli::kExitUsage;
  CLI::App app{
      "insid: identify INS sensor errors from navigation data, and benchmark the optimizers "
      "(GA, PSO, PIO, DVPIO) that do it."};
  app.require_subcommand(1);
  // The kernel's instruction-set path (kernel/cpu_path.h), decided here so that a bad INSID_CPU
  // stops every command before it starts, --version included.
  try {
    insid::cpu_path();
  } catch (const std::exception& e) {
    std::cerr << "insid: error: " << e.what() << '\n';
    return kExitFailure;
  }
  const nlohmann::json build = insid::build_info_json();
  app.set_version_flag(
      "--version",
      "insid " + build.value("version", "?") + "\n  git revision: " +
          build.value("git_revision", "?") + "\n  build type:   " + build.value("build_type", "?") +
          "\n  compiler:     " + build.value("compiler", "?") +
          "\n  CPU path:     " + build.value("cpu_path", "?"),
      "print the version, git revision, build type, compiler and CPU path, and exit");
  app.footer(insid::cli::kExitCodeHelp);
  insid::cli::add_navigate_command(app);
  insid::cli::add_identify_command(app);
  insid::cli::add_bench_command(app);
  insid::cli::add_sweep_command(app);
  insid::cli::add_merge_command(app);
  insid::cli::add_simulate_command(app);
  insid::cli::add_diagnose_command(app);
  insid::cli::add_import_command(app);
  insid::cli::add_export_command(app);
  insid::cli::add_cross_imu_command(app);
  // One error prefix, "insid <command>: error: ", and three exit codes (kExitCodeHelp).
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    const std::string command = command_path(app);
    std::string what = e.what();
    if (command == "insid" && argc > 1 && argv[1][0] != '-') {  // CLI11: "A subcommand is required"
      what = "unknown command '" + std::string(argv[1]) + "'; the commands are";
      for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        what += " " + sub->get_name();
    }
    std::cerr << command << ": error: " << what << "\nRun '" << command
              << " --help' for the options.\n";
    return kExitUsage;  // every CLI11 parse error (its codes 100-114) is a usage error
  } catch (const insid::campaign::ReportedError&) {
    return kExitFailure;  // printed by every MPI rank already
  } catch (const insid::cli::UsageError& e) {
    const std::string command = command_path(app);
    std::cerr << command << ": error: " << e.what() << "\nRun '" << command
              << " --help' for the options.\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << command_path(app) << ": error: " << e.what() << '\n';
    return kExitFailure;
  }
  return 0;
}
