// insid navigate: alignment + pure-INS navigation over a dataset, with optional compensation.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/json_reader.h"
#include "base/number_text.h"
#include "cli/cli_util.h"
#include "cli/commands.h"
#include "cli/initial_attitude_cli.h"
#include "cli/progress.h"
#include "data/dataset.h"
#include "model/rotation.h"
#include "model/units.h"
#include "nav/fitness.h"
#include "optimizers/parameters.h"

namespace insid::cli {
namespace {

struct NavigateArgs {
  std::string data_dir;
  std::vector<std::string> compensate;
  std::string compensate_from;
  InitialAttitudeArgs initial_attitude;
  std::string alignment = "per-candidate";
  double window_s = 0.0;
  std::string out_csv;
  std::string summary_path;
  bool force = false;
  Verbosity verbosity = Verbosity::kNormal;
};

// The estimates of an identify result (insid-identify/1 or /2): its `parameters` array (name,
// estimate in SI) when it has one, else its `estimate` object {name: SI value}; with gyro biases
// measured at rest (identify --gyro-bias-at-rest), those biases too (gyro_bias_at_rest.bias_deg_s,
// the motors-off b0 at the estimate). Throws naming the file and what it lacks.
std::map<std::string, double> identify_estimates(const std::string& path) {
  const std::string where = "--compensate-from " + path;
  nlohmann::json j;
  try {
    j = read_json_file(path, where);
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(e.what());
  }
  const std::string format = j.is_object() && j.contains("format") && j["format"].is_string()
                                 ? j["format"].get<std::string>()
                                 : "";
  if (format != "insid-identify/1" && format != "insid-identify/2")
    throw std::invalid_argument(
        where + ": not an identify result (\"format\" is " +
        (format.empty() ? std::string("missing") : "'" + format + "'") +
        ", expected insid-identify/1 or insid-identify/2, as written by insid identify --out)");
  std::map<std::string, double> estimates;
  const auto take = [&](const std::string& name, const nlohmann::json& value,
                        const std::string& field) {
    if (!value.is_number() || !std::isfinite(value.get<double>()))
      throw std::invalid_argument(where + ": " + field + " is " + value.dump() +
                                  ", expected a finite number (SI units)");
    effect_info(name);  // throws with the list of valid names
    estimates[name] = value.get<double>();
  };
  if (j.contains("parameters")) {
    const nlohmann::json& params = j["parameters"];
    if (!params.is_array() || params.empty())
      throw std::invalid_argument(where + ": \"parameters\" must be a non-empty array");
    for (std::size_t k = 0; k < params.size(); ++k) {
      const std::string field = "parameters[" + std::to_string(k) + "]";
      if (!params[k].is_object() || !params[k].contains("name") || !params[k]["name"].is_string() ||
          !params[k].contains("estimate"))
        throw std::invalid_argument(where + ": " + field + " needs \"name\" and \"estimate\"");
      take(params[k]["name"].get<std::string>(), params[k]["estimate"], field + ".estimate");
    }
  } else if (j.contains("estimate") && j["estimate"].is_object() && !j["estimate"].empty()) {
    for (const auto& [name, value] : j["estimate"].items()) take(name, value, "estimate." + name);
  } else {
    throw std::invalid_argument(where + ": neither \"parameters\" nor an \"estimate\" object");
  }
  if (j.contains("gyro_bias_at_rest")) {
    const nlohmann::json& rest = j["gyro_bias_at_rest"];
    const char* field = "gyro_bias_at_rest.bias_deg_s";
    if (!rest.is_object() || !rest.contains("bias_deg_s") || !rest["bias_deg_s"].is_array() ||
        rest["bias_deg_s"].size() != 3)
      throw std::invalid_argument(where + ": " + field + " must be an array of 3 numbers (deg/s)");
    const char* names[3] = {"gyro_bias_x", "gyro_bias_y", "gyro_bias_z"};
    for (int i = 0; i < 3; ++i) {
      const nlohmann::json& v = rest["bias_deg_s"][static_cast<std::size_t>(i)];
      if (estimates.count(names[i]))
        throw std::invalid_argument(where + ": " + names[i] + " is both estimated and in " + field);
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw std::invalid_argument(where + ": " + field + "[" + std::to_string(i) + "] is " +
                                    v.dump() + ", expected a finite number (deg/s)");
      estimates[names[i]] = v.get<double>() * kDegToRad;
    }
  }
  return estimates;
}

// A navigation that went non-finite is an error, never a result: name the first state that
// did, the IMU line it came from, and the compensation applied.
void require_finite_navigation(const NavigationProblem& problem, const std::string& data_dir,
                               const SensorErrors& candidate,
                               const std::optional<Eigen::Matrix3d>& C_b_n_override,
                               const std::vector<NavState>& states, const std::vector<double>& r) {
  const bool finite = std::all_of(states.begin(), states.end(),
                                  [](const NavState& s) {
                                    return std::isfinite(s.lat_rad) && std::isfinite(s.lon_rad) &&
                                           std::isfinite(s.h_m) && s.v_eb_n.allFinite() &&
                                           s.q_b_n.coeffs().allFinite();
                                  }) &&
                      std::all_of(r.begin(), r.end(), [](double v) { return std::isfinite(v); });
  if (finite) return;
  std::string compensation;
  for (const auto& [name, value] : nonzero_effects(candidate))
    compensation += (compensation.empty() ? "with --compensate " : ", ") + name + "=" +
                    opt::format_number(value);
  if (!compensation.empty()) compensation += ", ";
  throw std::runtime_error(data_dir + ": " + compensation +
                           problem.non_finite_report(candidate, C_b_n_override) +
                           "; no result is written");
}

void run_navigate(const NavigateArgs& args) {
  // The outputs are checked before the work: never an input, a file of others only with --force.
  OutputGuard guard{dataset_input_files(args.data_dir), args.force};
  if (!args.compensate_from.empty()) guard.inputs.emplace_back(args.compensate_from);
  check_distinct_outputs({{"--out", args.out_csv}, {"--summary", args.summary_path}});
  check_output_file(args.out_csv, guard);
  check_output_file(args.summary_path, guard);
  auto dataset = std::make_shared<const Dataset>(load_dataset(args.data_dir));
  const nlohmann::json plausibility = check_dataset_plausibility(*dataset, "insid navigate");
  ProgressPrinter progress("insid navigate", args.verbosity);
  std::map<std::string, double> compensation;
  if (!args.compensate_from.empty()) compensation = identify_estimates(args.compensate_from);
  const std::map<std::string, double> assignments = parse_option(
      "--compensate", [&] { return parse_effect_assignments(args.compensate, "--compensate"); });
  for (const auto& [name, value] : assignments) {
    if (compensation.count(name))
      throw UsageError("--compensate " + name + " is also in --compensate-from " +
                       args.compensate_from + ": give each effect once");
    compensation[name] = value;
  }
  for (const auto& [name, value] : compensation)
    progress.detail("compensating " + name + " = " + opt::format_number(value) + " (SI)");
  const SensorErrors candidate = errors_from_map(compensation);
  NavigationOptions options;
  options.alignment =
      parse_option("--alignment", [&] { return alignment_mode_from_string(args.alignment); });
  options.window_s = args.window_s;
  options.initial_attitude = initial_attitude_options(args.initial_attitude);
  const NavigationProblem problem(dataset, options);

  // Every mode, truth included, lives in the problem (nav/alignment.h); no override here.
  const std::optional<Eigen::Matrix3d> C_b_n_override;

  std::vector<NavState> states;
  states.reserve(problem.num_steps());
  std::vector<double> r;
  problem.run(
      candidate, C_b_n_override, [&](const NavState& s) { states.push_back(s); }, r);
  require_finite_navigation(problem, args.data_dir, candidate, C_b_n_override, states, r);

  double fitness = 0.0, sum_sq = 0.0, max_dvh = 0.0;
  for (std::size_t e = 0; e < problem.num_epochs(); ++e) {
    const double dvh = std::hypot(r[2 * e], r[2 * e + 1]);
    fitness += dvh;  // Eq. 15
    sum_sq += dvh * dvh;
    max_dvh = std::max(max_dvh, dvh);
  }
  nlohmann::json summary;
  summary["data"] = args.data_dir;
  summary["plausibility"] = plausibility;
  summary["alignment"] = to_string(options.alignment);
  summary["window_s"] = options.window_s;
  summary["windows"] = problem.num_windows();
  summary["initial_attitude"] = to_string(options.initial_attitude.mode);
  summary["compensate"] = nonzero_effects(candidate);
  if (!args.compensate_from.empty()) summary["compensate_from"] = args.compensate_from;
  summary["nav_start_t_s"] = problem.nav_start_t_s();
  summary["epochs"] = problem.num_epochs();
  summary["fitness"] = fitness;
  summary["sum_squares"] = sum_sq;
  summary["rms_dvh_mps"] = std::sqrt(sum_sq / static_cast<double>(problem.num_epochs()));
  summary["max_dvh_mps"] = max_dvh;
  const EulerAngles att0 = euler_from_C_b_n(states.empty() ? Eigen::Matrix3d::Identity()
                                                           : problem.initial_attitude(candidate));
  summary["initial_attitude_deg"] = {{"roll", att0.roll_rad * kRadToDeg},
                                     {"pitch", att0.pitch_rad * kRadToDeg},
                                     {"yaw", wrap_two_pi(att0.yaw_rad) * kRadToDeg}};
  summary["initial_attitude_detail"] = initial_attitude_json(problem, candidate);

  // Errors against truth (at the truth epochs inside the navigation span, nearest INS epoch
  // interpolated linearly).
  if (!dataset->truth.empty() && !states.empty()) {
    const EarthModel& earth = dataset->meta.earth;
    double max_dv = 0.0, max_dp = 0.0;
    std::size_t j = 0;
    for (const TruthSample& tr : dataset->truth) {
      if (tr.t_s < states.front().t_s - 1e-9 || tr.t_s > states.back().t_s + 1e-9) continue;
      while (j + 1 < states.size() && states[j + 1].t_s <= tr.t_s + 1e-12) ++j;
      const NavState& a = states[j];
      const NavState& b = states[std::min(j + 1, states.size() - 1)];
      const double w =
          b.t_s > a.t_s ? std::clamp((tr.t_s - a.t_s) / (b.t_s - a.t_s), 0.0, 1.0) : 0.0;
      const Eigen::Vector3d v = a.v_eb_n + w * (b.v_eb_n - a.v_eb_n);
      const double lat = a.lat_rad + w * (b.lat_rad - a.lat_rad);
      const double lon = a.lon_rad + w * (b.lon_rad - a.lon_rad);
      max_dv = std::max(max_dv, std::hypot(v.x() - tr.v_eb_n_mps.x(), v.y() - tr.v_eb_n_mps.y()));
      const double dn = (lat - tr.lat_rad) * (earth.meridian_radius_m(tr.lat_rad) + tr.h_m);
      const double de = (lon - tr.lon_rad) * (earth.prime_vertical_radius_m(tr.lat_rad) + tr.h_m) *
                        std::cos(tr.lat_rad);
      max_dp = std::max(max_dp, std::hypot(dn, de));
    }
    summary["max_dvh_truth_mps"] = max_dv;
    summary["max_dph_truth_m"] = max_dp;
  }

  if (!args.out_csv.empty()) {
    std::string text = "t_s,lat_deg,lon_deg,h_m,vE_mps,vN_mps,vU_mps,roll_deg,pitch_deg,yaw_deg\n";
    text.reserve(states.size() * 190);
    char line[512];
    for (const NavState& s : states) {
      const EulerAngles e = euler_from_q_b_n(s.q_b_n);
      std::snprintf(line, sizeof line,
                    "%.6f,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", s.t_s,
                    s.lat_rad * kRadToDeg, s.lon_rad * kRadToDeg, s.h_m, s.v_eb_n.x(), s.v_eb_n.y(),
                    s.v_eb_n.z(), e.roll_rad * kRadToDeg, e.pitch_rad * kRadToDeg,
                    wrap_two_pi(e.yaw_rad) * kRadToDeg);
      text += line;
    }
    write_output_file(args.out_csv, text, guard);
    progress.detail("wrote " + args.out_csv + " (" + std::to_string(states.size()) + " rows)");
  }
  progress.detail("Eq. 15 fitness " + number_text(fitness, 6) + " m/s over " +
                  std::to_string(problem.num_epochs()) + " GNSS epochs");
  write_json_output(args.summary_path, summary, guard);
}

}  // namespace

void add_navigate_command(CLI::App& app) {
  auto args = std::make_shared<NavigateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "navigate",
      "Align and run pure-INS navigation over a dataset; write the solution (CSV) and a JSON "
      "summary (Eq. 15 fitness, INS-minus-GNSS and INS-minus-truth errors).");
  cmd->add_option("--data", args->data_dir, "dataset directory (insid-dataset/1)")->required();
  cmd->add_option("--compensate", args->compensate,
                  "NAME=VALUE: compensate a catalogue error (SI units), repeatable");
  cmd->add_option("--compensate-from", args->compensate_from,
                  "identify result JSON (insid identify --out): compensate its estimates (its "
                  "\"parameters\", else its \"estimate\"); --compensate adds other effects");
  add_initial_attitude_options(cmd, args->initial_attitude);
  cmd->add_option("--alignment", args->alignment, "per-candidate | fixed")->capture_default_str();
  cmd->add_option("--window-s", args->window_s, kWindowHelp)
      ->capture_default_str()
      ->check(number_in(0.0, kMaxWindowS));
  cmd->add_option("--out", args->out_csv, "navigation solution CSV (truth.csv columns)");
  cmd->add_option("--summary", args->summary_path, "summary JSON file (default: stdout)");
  add_output_force_flag(cmd, &args->force);
  add_verbosity_flags(cmd, args->verbosity);
  cmd->callback([args] { run_navigate(*args); });
}

}  // namespace insid::cli
