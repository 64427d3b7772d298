// insid: identify INS sensor errors from flight data and benchmark the optimizers that do it.
#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench/campaign.h"
#include "cli/commands.h"
#include "identification/ekf_rts.h"
#include "identification/identify.h"

int main(int argc, char** argv) {
  CLI::App app{
      "insid: identify INS sensor errors from navigation data, and benchmark the optimizers "
      "(GA, PSO, PIO, DVPIO) that do it."};
  app.require_subcommand(1);
  const nlohmann::json build = insid::build_info_json();
  app.set_version_flag(
      "--version",
      "insid " + build.value("version", "?") + "\n  git revision: " + build.value("git_revision", "?") +
          "\n  build type:   " + build.value("build_type", "?") +
          "\n  compiler:     " + build.value("compiler", "?") +
          "\n  CPU path:     " + build.value("cpu_path", "?"),
      "print the version, git revision, build type, compiler and CPU path, and exit");
  insid::register_ekf_rts();  // "ekf-rts" in the optimizer registry (identification/)
  insid::cli::add_navigate_command(app);
  insid::cli::add_identify_command(app);
  insid::cli::add_bench_command(app);
  insid::cli::add_sweep_command(app);
  insid::cli::add_merge_command(app);
  insid::cli::add_simulate_command(app);
  insid::cli::add_diagnose_command(app);
  insid::cli::add_import_command(app);
  insid::cli::add_export_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const insid::campaign::ReportedError&) {
    return 1;  // printed by every MPI rank already
  } catch (const std::exception& e) {
    std::cerr << "insid: error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
