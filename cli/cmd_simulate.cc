// insid simulate: scenario preset or JSON file -> insid-dataset/1 directory (scenarios/).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "data/dataset.h"
#include "scenarios/scenario.h"

namespace insid::cli {
namespace {

struct SimulateArgs {
  std::string preset;
  std::string config;
  std::string out;
  std::optional<std::uint64_t> seed;
  std::string grade;
  std::optional<double> flight_s;
  std::vector<std::string> set;
  bool no_injected = false;
  bool clean = false;
  bool print_config = false;
  bool force = false;
  Verbosity verbosity = Verbosity::kNormal;
  std::string heading;  ///< "" | dual_antenna | magnetometer
  insid::scenarios::HeadingStreamSpec heading_spec;
};

void run_simulate(const SimulateArgs& args) {
  namespace sc = insid::scenarios;
  if (args.preset.empty() == args.config.empty())
    throw UsageError("give exactly one of --preset NAME or --config FILE");
  const sc::ScenarioConfig base =
      args.preset.empty()
          ? sc::load_scenario_file(args.config)
          : parse_option("--preset", [&] { return sc::preset_scenario(args.preset); });
  sc::ScenarioOverrides overrides;
  overrides.seed = args.seed;
  if (!args.grade.empty()) {
    // an unknown grade is named before a bad --set, as always
    parse_option("--grade", [&] { return sc::noise_grade(args.grade); });
    overrides.grade = args.grade;
  }
  overrides.flight_s = args.flight_s;
  overrides.clean = args.clean;
  overrides.set = parse_option(  // on top of the preset's
      "--set", [&] { return parse_effect_assignments(args.set, "--set"); });
  const sc::ScenarioConfig cfg = sc::with_overrides(base, overrides);
  const sc::ScenarioPlan plan = sc::plan_scenario(cfg);  // all checks before any work
  sc::HeadingStreamSpec heading_spec = args.heading_spec;
  if (!args.heading.empty()) {
    if (args.heading == "dual_antenna")
      heading_spec.source = HeadingSourceKind::kDualAntenna;
    else if (args.heading == "magnetometer")
      heading_spec.source = HeadingSourceKind::kMagnetometer;
    else
      throw UsageError("--heading '" + args.heading + "': must be dual_antenna or magnetometer");
    heading_spec.seed = cfg.seed;
    if (const std::string why = heading_spec.validate(); !why.empty()) throw UsageError(why);
  }

  if (args.print_config) {
    std::cout << sc::scenario_to_json(cfg).dump(2) << "\n";
    return;
  }
  if (args.out.empty()) throw UsageError("--out DIR is required");
  // Refuse a directory before the work, not after; the config read is never replaced.
  std::vector<std::filesystem::path> inputs;
  if (!args.config.empty()) inputs.emplace_back(args.config);
  dataset_destination(args.out, args.force, inputs);

  ProgressPrinter progress("insid simulate", args.verbosity);
  char line[512];
  std::snprintf(line, sizeof line,
                "'%s', %.0f s alignment + %.0f s flight, IMU %g Hz (%zu rows), GNSS %g Hz (%zu "
                "rows), noise grade '%s', seed %llu ...",
                cfg.name.c_str(), cfg.align_s, plan.flight_s, cfg.imu_rate_hz, plan.num_imu_steps,
                cfg.gnss_rate_hz, plan.num_gnss, cfg.noise.grade.c_str(),
                static_cast<unsigned long long>(cfg.seed));
  progress.note(line);
  const auto t0 = std::chrono::steady_clock::now();
  Dataset ds = sc::simulate(cfg, plan, !args.no_injected);
  if (!args.heading.empty()) sc::add_heading_stream(ds, heading_spec);
  DatasetWriteOptions write_options;
  write_options.into_foreign_directory = args.force;
  write_options.inputs = inputs;
  if (args.no_injected)
    write_options.extra_files["answer.json"] = sc::answer_json(cfg).dump(2) + "\n";
  write_dataset(args.out, ds, write_options);  // atomic: nothing half-written on failure
  std::snprintf(line, sizeof line, "%.1f",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  progress.note("wrote " + args.out + " in " + line + " s");
}

}  // namespace

void add_simulate_command(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  std::string presets;
  for (const std::string& n : insid::scenarios::preset_names())
    presets += (presets.empty() ? "" : "|") + n;
  CLI::App* cmd = app.add_subcommand(
      "simulate",
      "Synthesize a drone flight (exact IMU increments, GNSS, truth) with injected sensor errors "
      "and noise, and write an insid-dataset/1 directory. Scenario keys: scenarios/README.md.");
  cmd->add_option("--preset", args->preset, "built-in scenario: " + presets);
  cmd->add_option("--config", args->config, "scenario JSON file");
  cmd->add_option("--out", args->out,
                  "output dataset directory: new, empty or an insid dataset (replaced atomically)");
  cmd->add_flag("--force", args->force,
                "write into a --out directory that holds other files: add the dataset's files, "
                "keep everything else");
  cmd->add_option("--seed", args->seed, "random seed (default: the scenario's, else 1)")
      ->check(seed_value());
  cmd->add_option("--grade", args->grade,
                  "noise grade nav|mems|paper|none (replaces the scenario's noise block)");
  cmd->add_option("--flight-s", args->flight_s,
                  "flight after the alignment (s); the scenario's 'repeat' segments fill it")
      ->check(positive_seconds(kMaxFlightS));
  cmd->add_option("--set", args->set,
                  "NAME=VALUE: inject a catalogue error (SI units) on top of the scenario's; "
                  "repeatable");
  cmd->add_flag("--clean", args->clean, "drop the scenario's own injected errors");
  cmd->add_flag("--no-injected", args->no_injected,
                "leave 'injected' and 'noise' out of meta.json (data that look measured) and "
                "write the truth to answer.json in the dataset directory");
  cmd->add_flag("--print-config", args->print_config,
                "print the effective scenario JSON (after the options) and exit");
  add_verbosity_flags(cmd, args->verbosity);
  CLI::Option* heading = cmd->add_option(
      "--heading", args->heading,
      "also write a measured heading (heading.csv): dual_antenna (truth yaw + white "
      "noise of --heading-sd-deg) | magnetometer (the Earth field in the body with "
      "noise, levelled on the static window and --declination-deg added, as insid "
      "import does; static window only)");
  cmd->add_option("--heading-rate-hz", args->heading_spec.rate_hz, "heading samples per second")
      ->capture_default_str()
      ->needs(heading);  // without --heading it would be silently ignored: a usage error
  cmd->add_option("--heading-sd-deg", args->heading_spec.sd_deg,
                  "dual antenna: the heading's white noise sd (deg)")
      ->capture_default_str()
      ->needs(heading);  // without --heading it would be silently ignored: a usage error
  cmd->add_option("--declination-deg", args->heading_spec.declination_deg,
                  "magnetometer: the field's declination (deg, east +)")
      ->capture_default_str()
      ->needs(heading);  // without --heading it would be silently ignored: a usage error
  cmd->add_option("--inclination-deg", args->heading_spec.inclination_deg,
                  "magnetometer: the field's inclination (deg, down +)")
      ->capture_default_str()
      ->needs(heading);  // without --heading it would be silently ignored: a usage error
  cmd->add_option("--mag-noise", args->heading_spec.mag_noise_fraction,
                  "magnetometer: white noise per axis, a fraction of the field")
      ->capture_default_str()
      ->needs(heading);  // without --heading it would be silently ignored: a usage error
  cmd->callback([args] { run_simulate(*args); });
}

}  // namespace insid::cli
