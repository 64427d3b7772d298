// insid cross-imu: the gyro bias differences between IMUs on one airframe, measured directly
// from their samples (diagnose/cross_imu.h), and insid's estimated differences held against them.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/json_object.h"
#include "base/json_reader.h"
#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "data/dataset.h"
#include "diagnose/cross_imu.h"
#include "kernel/build_info.h"
#include "model/units.h"

namespace insid::cli {
namespace {
namespace fs = std::filesystem;

struct CrossImuArgs {
  std::vector<std::string> data;
  std::vector<std::string> results;
  std::optional<double> t_start_s, t_end_s;
  std::string clock = "dataset";
  double block_s = cross_imu::CrossImuOptions{}.block_s;
  double segment_s = cross_imu::CrossImuOptions{}.segment_s;
  double min_rate_sd_deg_s = cross_imu::CrossImuOptions{}.min_rate_sd_rad_s * kRadToDeg;
  std::string out, markdown;
  bool force = false;
  Verbosity verbosity = Verbosity::kNormal;
};

// The dataset's boot clock as (offset, scale): boot = (t_s + offset) * scale, from its
// provenance.json (insid import ardupilot: the GPST fit of the boot clock; insid import ulog:
// time_origin_boot_s). Throws naming the dataset when it has none.
std::pair<double, double> boot_clock(const std::string& dir) {
  const fs::path prov_path = fs::path(dir) / "provenance.json";
  if (!fs::exists(prov_path))
    throw UsageError("--clock boot: " + dir +
                     " has no provenance.json (only datasets written by insid import ardupilot "
                     "or ulog carry a boot clock); use --clock dataset");
  const nlohmann::json prov = read_json_file(prov_path);
  const std::string src = prov_path.string();
  try {
    const JsonObject p = JsonObject::with_other_keys(
        prov, src, "", {"time_origin_boot_s", "time_origin_gpst_unix_s", "clock"});
    if (p.given("time_origin_boot_s")) return {p.number("time_origin_boot_s"), 1.0};
    if (p.given("clock") && p.given("time_origin_gpst_unix_s")) {
      const JsonObject c = JsonObject::with_other_keys(p.field("clock").value(), src, "clock",
                                                       {"gpst_at_boot_zero_unix_s", "slope"});
      const double slope = c.number("slope");
      if (!(slope > 0.5 && slope < 2.0))
        c.field("slope").fail("not a clock slope: " + std::to_string(slope));
      // boot = (GPST - gpst_at_boot_zero) / slope, GPST = t_s + time_origin.
      return {p.number("time_origin_gpst_unix_s") - c.number("gpst_at_boot_zero_unix_s"),
              1.0 / slope};
    }
  } catch (const JsonFieldError& e) {
    throw std::runtime_error(e.what());
  }
  throw UsageError("--clock boot: " + src +
                   " records no boot clock (time_origin_boot_s, or clock with "
                   "time_origin_gpst_unix_s); use --clock dataset");
}

void run_cross_imu(const CrossImuArgs& args) {
  if (args.data.size() < 2)
    throw UsageError("--data: give at least two datasets (one per IMU of the airframe), got " +
                     std::to_string(args.data.size()));
  if (!args.results.empty() && args.results.size() != args.data.size())
    throw UsageError("--result: " + std::to_string(args.results.size()) + " results for " +
                     std::to_string(args.data.size()) +
                     " datasets; give one insid identify result per --data, in the same order");
  if (args.clock != "dataset" && args.clock != "boot")
    throw UsageError("--clock '" + args.clock + "': must be dataset or boot");
  cross_imu::CrossImuOptions options;
  options.t_start_s = args.t_start_s;
  options.t_end_s = args.t_end_s;
  options.block_s = args.block_s;
  options.segment_s = args.segment_s;
  options.min_rate_sd_rad_s = args.min_rate_sd_deg_s * kDegToRad;
  if (const std::string e = options.validate(); !e.empty()) throw UsageError(e);
  {
    std::set<std::string> seen;
    for (const std::string& d : args.data) {
      std::error_code ec;
      const std::string key = fs::weakly_canonical(d, ec).string();
      if (!seen.insert(ec ? d : key).second)
        throw UsageError("--data " + d + " is given twice: each IMU once");
    }
  }
  // The outputs, checked before the work: never an input, a file of others only with --force.
  OutputGuard guard;
  guard.force = args.force;
  for (const std::string& d : args.data)
    for (const fs::path& p : dataset_input_files(d)) guard.inputs.push_back(p);
  for (const std::string& r : args.results) guard.inputs.emplace_back(r);
  check_distinct_outputs({{"--out", args.out}, {"--markdown", args.markdown}});
  check_output_file(args.out, guard);
  check_output_file(args.markdown, guard);

  ProgressPrinter progress("insid cross-imu", args.verbosity);
  std::vector<cross_imu::RateSeries> series;
  std::vector<std::string> names;
  for (const std::string& d : args.data) {
    std::string name = fs::path(d).lexically_normal().filename().string();
    if (name.empty() || name == "." || name == "..") name = d;
    for (const std::string& n : names)
      if (n == name) name = d;  // two directories with one name: the paths tell them apart
    names.push_back(name);
    const Dataset ds = load_dataset(d);
    double offset = 0.0, scale = 1.0;
    if (args.clock == "boot") std::tie(offset, scale) = boot_clock(d);
    series.push_back(cross_imu::rates_from_dataset(ds, name, offset, scale));
  }
  std::vector<cross_imu::ResultEstimates> results;
  for (const std::string& r : args.results) results.push_back(cross_imu::read_identify_result(r));

  const cross_imu::CrossImuReport report = cross_imu::direct_differences(series, options);
  std::optional<std::vector<cross_imu::ComparisonRow>> rows;
  if (!results.empty()) rows = cross_imu::compare_with_results(report, results);
  const std::vector<cross_imu::ComparisonRow>* rows_ptr = rows ? &*rows : nullptr;

  // The tables go to stderr unless --quiet; the warnings always.
  if (!progress.quiet()) std::cerr << cross_imu::report_text(report, rows_ptr);
  if (rows)
    for (const std::string& w : cross_imu::comparison_warnings(report, *rows))
      std::cerr << "insid cross-imu: warning: " << w << "\n";

  nlohmann::json j = cross_imu::report_json(report, rows_ptr);
  j["clock"] = args.clock == "boot" ? "boot seconds (each dataset's provenance.json)"
                                    : "dataset seconds (imu.csv t_s)";
  j["data"] = args.data;
  j["results"] = args.results;
  j["insid"] = build_info_json();
  if (!args.out.empty()) write_json_output(args.out, j, guard);
  if (!args.markdown.empty()) {
    std::string md = "# Cross-IMU check: " + std::to_string(args.data.size()) + " IMUs\n\n";
    md += "Written by `insid cross-imu` (" + j["insid"].value("git_revision", "?") +
          "); times in " + j["clock"].get<std::string>() + ".\n\n";
    md += cross_imu::report_markdown(report, rows_ptr);
    write_output_file(args.markdown, md, guard);
  }
}

}  // namespace

void add_cross_imu_command(CLI::App& app) {
  auto a = std::make_shared<CrossImuArgs>();
  CLI::App* cmd = app.add_subcommand(
      "cross-imu",
      "The IMUs of one airframe against each other: per pair and gyro axis, the bias difference "
      "measured directly from the samples (the difference regressed on the rates, so that scale "
      "and misalignment differences are separated; standard errors from block averages, since "
      "vibration correlates the samples), per time segment too; with --result, insid's "
      "estimated differences held against them (z-score, verdict, warning). Gyros only: "
      "accelerometer differences carry lever-arm terms (README, 'The cross-IMU check').");
  cmd->add_option("--data", a->data,
                  "a dataset of one IMU (give it once per IMU, at least two; the first is the "
                  "reference of the independent pairs); the IMUs must be logged at the same "
                  "instants (e.g. insid import ardupilot --imu all)")
      ->required();
  cmd->add_option("--result", a->results,
                  "an insid identify result (insid-identify/2) of each --data, same order");
  cmd->add_option("--t-start", a->t_start_s, "first sample time used (s, on --clock)")
      ->check(number_in(-1e9, 1e9));
  cmd->add_option("--t-end", a->t_end_s, "last sample time used (s, on --clock)")
      ->check(number_in(-1e9, 1e9));
  cmd->add_option("--clock", a->clock,
                  "dataset (imu.csv t_s) | boot (the autopilot's boot seconds, from "
                  "provenance.json of insid import ardupilot / ulog)")
      ->capture_default_str();
  cmd->add_option("--block-s", a->block_s,
                  "block length (s) of the standard errors (batch means; a window shorter than 10 "
                  "blocks uses window / 10); the SE at 0.02-10 s is reported beside it")
      ->capture_default_str()
      ->check(number_in(1e-3, 1e6));
  cmd->add_option("--segment-s", a->segment_s,
                  "the bias differences are also given per segment of this length (s)")
      ->capture_default_str()
      ->check(number_in(1e-3, 1e7));
  cmd->add_option("--min-rate-sd-deg-s", a->min_rate_sd_deg_s,
                  "a rate axis enters the regression only when its sd over the window reaches "
                  "this (deg/s); below it the rates are noise, not motion")
      ->capture_default_str()
      ->check(number_in(0, 1e4));
  cmd->add_option("--out", a->out, "the report as JSON (insid-cross-imu/1; - for stdout)");
  cmd->add_option("--markdown", a->markdown, "the tables as markdown");
  add_output_force_flag(cmd, &a->force);
  add_verbosity_flags(cmd, a->verbosity);
  cmd->callback([a] { run_cross_imu(*a); });
}

}  // namespace insid::cli
