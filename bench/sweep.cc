#include "bench/sweep.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "base/json_reader.h"
#include "bench/stats.h"
#include "data/dataset.h"
#include "identification/ins_problem.h"
#include "optimizers/random.h"
#include "optimizers/registry.h"

namespace insid::campaign {
namespace fs = std::filesystem;

namespace {

double parse_value(const std::string& text, const std::string& spec) {
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(v))
    throw std::invalid_argument("--grid '" + spec + "': expected a finite number, got '" + text +
                                "'");
  return v;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, sep);) out.push_back(part);
  return out;
}

// Setting values in the optimizer's units: NAME_sigma for a distance parameter NAME is that
// distance in sigma units, converted through the (common) box width of the estimated parameters
// (ParameterMapping::algorithm_parameter_in_box); every other key (ekf-rts's own
// initial_bias_sigma included) passes unchanged, as in identify --param. "d0" is d_initial.
std::map<std::string, double> optimizer_parameters(const std::map<std::string, double>& setting,
                                                   const std::string& algorithm) {
  const ParameterMapping mapping(EstimatedParameter::paper_four());
  const opt::ParameterInfoList own = opt::parameter_info(algorithm);
  std::map<std::string, double> out;
  for (const auto& [key_in, value_in] : setting) {
    std::string name = key_in;
    if (name == "d0") name = "d_initial";
    if (name == "d0_sigma") name = "d_initial_sigma";
    const auto [key, value] = mapping.algorithm_parameter_in_box(name, value_in, own);
    out[key] = value;
  }
  return out;
}

}  // namespace

SweepAxis SweepAxis::parse(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    throw std::invalid_argument("--grid: expected KEY=LO:HI:N or KEY=V1,V2,..., got '" + text +
                                "'");
  SweepAxis axis;
  axis.key = text.substr(0, eq);
  const std::string rhs = text.substr(eq + 1);
  if (rhs.find(':') != std::string::npos) {
    const auto parts = split(rhs, ':');
    if (parts.size() != 3)
      throw std::invalid_argument("--grid '" + text + "': expected KEY=LO:HI:N");
    axis.lo = parse_value(parts[0], text);
    axis.hi = parse_value(parts[1], text);
    const double n = parse_value(parts[2], text);
    if (n < 1 || n != std::floor(n) || n > 1000)
      throw std::invalid_argument("--grid '" + text + "': N must be a whole number in [1, 1000]");
    if (!(axis.lo <= axis.hi))
      throw std::invalid_argument("--grid '" + text + "': LO must be <= HI");
    for (int i = 0; i < static_cast<int>(n); ++i)
      axis.values.push_back(n == 1 ? axis.lo : axis.lo + (axis.hi - axis.lo) * i / (n - 1));
  } else {
    for (const std::string& v : split(rhs, ',')) axis.values.push_back(parse_value(v, text));
    axis.lo = *std::min_element(axis.values.begin(), axis.values.end());
    axis.hi = *std::max_element(axis.values.begin(), axis.values.end());
  }
  return axis;
}

std::string SweepConfig::validate() const {
  if (axes.empty()) return "sweep: give at least one --grid";
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const SweepAxis& a = axes[i];
    for (std::size_t j = 0; j < i; ++j)
      if (a.key == axes[j].key)
        return "--grid: key '" + a.key + "' given twice; give each parameter one --grid";
    if (a.values.empty()) return "--grid " + a.key + ": no values";
    for (double v : a.values)
      if (!std::isfinite(v))
        return "--grid " + a.key + ": value " + std::to_string(v) + " is not a finite number";
    if (!(std::isfinite(a.lo) && std::isfinite(a.hi) && a.lo <= a.hi))
      return "--grid " + a.key + ": the range [" + std::to_string(a.lo) + ", " +
             std::to_string(a.hi) + "] must be finite with LO <= HI";
  }
  if (random_settings < 0) return "--random must be >= 0, got " + std::to_string(random_settings);
  if (seeds.empty()) return "sweep: no seed";
  if (max_iterations < 0)
    return "sweep: --iterations must be >= 0, got " + std::to_string(max_iterations);
  if (max_evaluations < 0)
    return "sweep: --evaluations must be >= 0, got " + std::to_string(max_evaluations);
  return "";
}

std::vector<std::map<std::string, double>> sweep_settings(const SweepConfig& sweep) {
  std::vector<std::map<std::string, double>> settings;
  if (const std::string why = sweep.validate(); !why.empty()) throw std::invalid_argument(why);
  if (sweep.random_settings > 0) {
    opt::Rng rng(sweep.random_seed);
    for (int i = 0; i < sweep.random_settings; ++i) {
      std::map<std::string, double> s;
      for (const SweepAxis& a : sweep.axes) s[a.key] = rng.uniform(a.lo, a.hi);
      settings.push_back(s);
    }
    return settings;
  }
  settings.push_back({});
  for (const SweepAxis& a : sweep.axes) {
    std::vector<std::map<std::string, double>> next;
    for (const auto& s : settings)
      for (double v : a.values) {
        auto t = s;
        t[a.key] = v;
        next.push_back(t);
      }
    settings.swap(next);
  }
  return settings;
}

CampaignConfig sweep_campaign(const SweepConfig& sweep) {
  nlohmann::json j;
  j["name"] = "sweep-" + sweep.algorithm;
  nlohmann::json sc = {{"name", sweep.scenario.name}};
  if (!sweep.scenario.preset.empty()) sc["preset"] = sweep.scenario.preset;
  if (!sweep.scenario.data_dir.empty()) sc["data"] = sweep.scenario.data_dir;
  if (sweep.scenario.flight_s) sc["flight_s"] = *sweep.scenario.flight_s;
  if (sweep.scenario.grade) sc["grade"] = *sweep.scenario.grade;
  sc["data_seed"] = sweep.scenario.data_seed;
  j["scenarios"] = {sc};
  const auto settings = sweep_settings(sweep);
  for (std::size_t i = 0; i < settings.size(); ++i) {
    std::ostringstream label;
    label << "s" << std::setw(4) << std::setfill('0') << i;
    j["algorithms"].push_back({{"label", label.str()},
                               {"name", sweep.algorithm},
                               {"parameters", optimizer_parameters(settings[i], sweep.algorithm)}});
  }
  j["seeds"] = sweep.seeds;
  j["max_iterations"] = sweep.max_iterations;
  j["max_evaluations"] = sweep.max_evaluations;
  j["alignment"] = to_string(sweep.alignment);
  if (sweep.initial_attitude) j["initial_attitude"] = to_string(*sweep.initial_attitude);
  if (sweep.heading_deg) j["heading_deg"] = *sweep.heading_deg;
  if (sweep.window_s != 0.0) j["window_s"] = sweep.window_s;
  if (sweep.estimation_grade) j["estimation_grade"] = *sweep.estimation_grade;
  j["record_positions_seeds"] = 0;
  return parse_campaign(j, "sweep");
}

nlohmann::json sweep_to_manifest(const SweepConfig& sweep) {
  nlohmann::json j;
  j["algorithm"] = sweep.algorithm;
  j["axes"] = nlohmann::json::array();
  for (const SweepAxis& a : sweep.axes)
    j["axes"].push_back({{"key", a.key}, {"values", a.values}, {"lo", a.lo}, {"hi", a.hi}});
  j["random_settings"] = sweep.random_settings;
  j["random_seed"] = sweep.random_seed;
  j["scenario"] = sweep.scenario.name;
  j["seeds"] = sweep.seeds;
  return j;
}

SweepConfig sweep_from_manifest(const nlohmann::json& j, const std::string& origin) {
  try {
    SweepConfig sweep;
    sweep.algorithm = j.at("algorithm").get<std::string>();
    for (const nlohmann::json& a : j.at("axes")) {
      SweepAxis axis;
      axis.key = a.at("key").get<std::string>();
      axis.values = a.at("values").get<std::vector<double>>();
      axis.lo = a.at("lo").get<double>();
      axis.hi = a.at("hi").get<double>();
      sweep.axes.push_back(axis);
    }
    sweep.random_settings = j.at("random_settings").get<int>();
    sweep.random_seed = j.at("random_seed").get<std::uint64_t>();
    sweep.scenario.name = j.at("scenario").get<std::string>();
    sweep.seeds = j.at("seeds").get<std::vector<std::uint64_t>>();
    return sweep;
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(origin + ": unreadable \"sweep\" entry (" + json_error_text(e) + ")");
  }
}

CampaignOutcome run_sweep(const SweepConfig& sweep, const RunOptions& options) {
  if (const std::string why = sweep.validate(); !why.empty()) throw std::invalid_argument(why);
  const CampaignConfig campaign = sweep_campaign(sweep);
  RunOptions sweep_options = options;
  sweep_options.manifest_extra["sweep"] = sweep_to_manifest(sweep);
  const CampaignOutcome outcome = run_campaign(campaign, sweep_options);
  if (outcome.complete && outcome.writes_results)
    write_sweep_results(sweep, campaign, options.out_dir);
  return outcome;
}

void write_sweep_results(const SweepConfig& sweep, const CampaignConfig& campaign,
                         const std::string& out_dir) {
  const auto settings = sweep_settings(sweep);
  if (settings.size() != campaign.algorithms.size())
    throw std::runtime_error(out_dir + ": the sweep has " + std::to_string(settings.size()) +
                             " settings but its campaign " +
                             std::to_string(campaign.algorithms.size()) + " algorithms");
  nlohmann::json out;
  out["schema"] = "insid-sweep/1";
  out["algorithm"] = sweep.algorithm;
  out["scenario"] = sweep.scenario.name;
  out["seeds"] = sweep.seeds;
  for (const SweepAxis& a : sweep.axes) out["grid"][a.key] = a.values;
  out["random_settings"] = sweep.random_settings;
  std::ostringstream csv;
  csv << "setting";
  for (const SweepAxis& a : sweep.axes) csv << "," << a.key;
  csv << ",fitness_median,fitness_q1,fitness_q3,fitness_median_ci95_lo,fitness_median_ci95_hi,"
         "error_norm_median,error_norm_q1,error_norm_q3\n";
  std::vector<std::pair<double, std::size_t>> ranking;
  for (std::size_t i = 0; i < settings.size(); ++i) {
    const AlgorithmSpec& algo = campaign.algorithms[i];
    std::vector<double> finals, errors;
    for (std::uint64_t seed : campaign.seeds) {
      const nlohmann::json r =
          read_run_record(run_file(out_dir, sweep.scenario.name, algo.label, seed),
                          sweep.scenario.name, algo.label, seed);
      finals.push_back(r["result"]["fitness"].get<double>());
      double sq = 0.0;
      for (const auto& item : r["error_vs_optimum_sigma"].items())
        sq += item.value().get<double>() * item.value().get<double>();
      errors.push_back(std::sqrt(sq));
    }
    const stats::Quartiles qf = stats::quartiles(finals);
    const stats::Quartiles qe = stats::quartiles(errors);
    const stats::ConfidenceInterval ci = stats::bootstrap_median_ci(finals, 0.95, 2000, 7 + i);
    nlohmann::json s;
    s["label"] = algo.label;
    s["parameters"] = settings[i];
    s["final_fitness"] = {{"median", qf.median}, {"q1", qf.q1}, {"q3", qf.q3}};
    s["median_ci95"] = {ci.lo, ci.hi};
    s["error_sigma_norm"] = {{"median", qe.median}, {"q1", qe.q1}, {"q3", qe.q3}};
    out["settings"].push_back(s);
    ranking.emplace_back(qf.median, i);
    csv << algo.label;
    for (const SweepAxis& a : sweep.axes) csv << "," << settings[i].at(a.key);
    csv << "," << qf.median << "," << qf.q1 << "," << qf.q3 << "," << ci.lo << "," << ci.hi << ","
        << qe.median << "," << qe.q1 << "," << qe.q3 << "\n";
  }
  std::sort(ranking.begin(), ranking.end());
  for (std::size_t r = 0; r < std::min<std::size_t>(5, ranking.size()); ++r)
    out["best"].push_back(out["settings"][ranking[r].second]);
  // The campaign directory's own paths (accepted by the campaign, bench/campaign.cc): replaced
  // whoever wrote the bytes there, never through a link.
  WriteOptions own;
  own.replace_foreign = true;
  write_file_atomic(fs::path(out_dir) / "sweep.json", out.dump(1) + "\n", own);
  write_file_atomic(fs::path(out_dir) / "sweep.csv", csv.str(), own);
}

int merge_results(const std::string& dir) {
  const fs::path manifest_path = fs::path(dir) / "manifest.json";
  std::error_code ec;
  if (!fs::is_regular_file(manifest_path, ec))
    throw std::runtime_error("cannot read " + manifest_path.string() +
                             ": not a campaign directory (run insid bench or sweep there first)");
  const nlohmann::json manifest = read_json_file(manifest_path);
  const CampaignConfig campaign = config_from_manifest(manifest, manifest_path.string());
  const std::string missing = missing_runs_report(dir, campaign, manifest.value("shards", 0));
  if (!missing.empty()) throw std::runtime_error("cannot merge: " + missing);
  WriteOptions own;
  own.replace_foreign = true;  // a directory with insid's manifest (checked above)
  write_file_atomic(fs::path(dir) / "summary.json",
                    summarize_campaign(dir, campaign).dump(1) + "\n", own);
  if (manifest.contains("sweep"))
    write_sweep_results(sweep_from_manifest(manifest.at("sweep"), manifest_path.string()), campaign,
                        dir);
  return static_cast<int>(campaign.scenarios.size() * campaign.algorithms.size() *
                          campaign.seeds.size());
}

}  // namespace insid::campaign
