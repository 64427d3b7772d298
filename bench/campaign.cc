#include "bench/campaign.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <span>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "bench/cluster.h"
#include "core/json_reader.h"
#include "core/output_dir.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "optimizers/registry.h"
#include "scenarios/scenario.h"

namespace insid::campaign {
namespace fs = std::filesystem;

namespace {

constexpr const char* kManifestSchema = "insid-campaign/1";
// insid-run/2 renamed "estimate_sigma" (the estimate in sigma units, read as an sd) to
// "estimate_in_sigma_units" (issue 15); insid-run/1 records are still read (resume, merge).
constexpr const char* kRunSchema = "insid-run/2";
constexpr const char* kRunSchemaOld = "insid-run/1";

// Strict JSON object reader: every key must be consumed, unknown keys are errors.
class Reader {
 public:
  Reader(const nlohmann::json& j, std::string where) : j_(j), where_(std::move(where)) {
    if (!j_.is_object()) throw std::invalid_argument(where_ + ": expected a JSON object");
  }
  bool has(const std::string& key) const { return j_.contains(key); }
  const nlohmann::json& at(const std::string& key) {
    used_.insert(key);
    if (!j_.contains(key)) throw std::invalid_argument(where_ + ": missing key \"" + key + "\"");
    return j_.at(key);
  }
  double number(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_number()) throw std::invalid_argument(where_ + ": \"" + key + "\" must be a number");
    return v.get<double>();
  }
  const nlohmann::json& array(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_array())
      throw std::invalid_argument(where_ + ": \"" + key + "\" must be an array, got " +
                                  v.type_name() + " " + v.dump());
    return v;
  }
  // An array of `type` ("string" or "number") items.
  const nlohmann::json& array_of(const std::string& key, const std::string& type) {
    const nlohmann::json& v = array(key);
    for (std::size_t k = 0; k < v.size(); ++k)
      if ((type == "string" && !v[k].is_string()) || (type == "number" && !v[k].is_number()))
        throw std::invalid_argument(where_ + ": \"" + key + "\"[" + std::to_string(k) +
                                    "] must be a " + type + ", got " + v[k].dump());
    return v;
  }
  std::string string(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_string()) throw std::invalid_argument(where_ + ": \"" + key + "\" must be a string");
    return v.get<std::string>();
  }
  void finish(const std::vector<std::string>& allowed) const {
    for (const auto& item : j_.items()) {
      if (std::find(allowed.begin(), allowed.end(), item.key()) == allowed.end()) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        throw std::invalid_argument(where_ + ": unknown key \"" + item.key() +
                                    "\"; valid keys: " + list);
      }
    }
  }

 private:
  const nlohmann::json& j_;
  std::string where_;
  std::set<std::string> used_;
};

int whole(double v, const std::string& what) {
  if (v != std::floor(v) || v < 0 || v > 1e9)
    throw std::invalid_argument(what + " must be a non-negative whole number, got " +
                                std::to_string(v));
  return static_cast<int>(v);
}

std::string host_name() {
  char buffer[256] = {0};
  if (gethostname(buffer, sizeof(buffer) - 1) != 0) return "unknown";
  return buffer;
}

// Why a run record cannot be used ("" when it can): it names this run under the current schema
// and every number the summary and the sweep read is a finite number.
std::string run_record_problem(const nlohmann::json& j, const std::string& scenario,
                               const std::string& label, std::uint64_t seed) {
  if (!j.is_object()) return "the top level is " + std::string(j.type_name()) + ", not an object";
  const auto text_field = [&](const char* key, const std::string& want) -> std::string {
    const auto it = j.find(key);
    if (it == j.end() || !it->is_string()) return std::string("field \"") + key + "\" is not a string";
    if (it->get<std::string>() != want)
      return std::string("field \"") + key + "\" is \"" + it->get<std::string>() + "\", expected \"" +
             want + "\"";
    return "";
  };
  const std::string schema = j.contains("schema") && j["schema"].is_string() &&
                                    j["schema"].get<std::string>() == kRunSchemaOld
                                ? kRunSchemaOld
                                : kRunSchema;
  for (const auto& [key, want] : {std::pair<const char*, std::string>{"schema", schema},
                                  {"scenario", scenario},
                                  {"algorithm", label}})
    if (std::string p = text_field(key, want); !p.empty()) return p;
  if (!j.contains("seed") || !j["seed"].is_number_unsigned() || j["seed"].get<std::uint64_t>() != seed)
    return "field \"seed\" is not " + std::to_string(seed);
  const auto finite = [](const nlohmann::json& v) {
    return v.is_number() && std::isfinite(v.get<double>());
  };
  const auto number_problem = [&](const nlohmann::json& obj, const std::string& path,
                                  const char* key) -> std::string {
    if (!obj.is_object() || !obj.contains(key)) return "field \"" + path + key + "\" is missing";
    if (!finite(obj[key]))
      return "field \"" + path + key + "\" must be a finite number, got " +
             (obj[key].is_number() ? obj[key].dump() : std::string(obj[key].type_name()));
    return "";
  };
  if (!j.contains("result") || !j["result"].is_object()) return "field \"result\" is not an object";
  const nlohmann::json& result = j["result"];
  for (const char* key : {"fitness", "wall_s", "evaluations"})
    if (std::string p = number_problem(result, "result.", key); !p.empty()) return p;
  if (std::string p = number_problem(j, "", "optimum_fitness"); !p.empty()) return p;
  const auto history = result.find("history");
  if (history == result.end() || !history->is_array() || history->empty())
    return "field \"result.history\" is not a non-empty array";
  for (std::size_t i = 0; i < history->size(); ++i)
    if (std::string p = number_problem((*history)[i], "result.history[" + std::to_string(i) + "].",
                                       "best_fitness");
        !p.empty())
      return p;
  const auto trace = result.find("best_per_evaluation");
  if (trace == result.end() || !trace->is_array() || trace->empty())
    return "field \"result.best_per_evaluation\" is not a non-empty array";
  for (std::size_t i = 0; i < trace->size(); ++i)
    if (!finite((*trace)[i]))
      return "field \"result.best_per_evaluation[" + std::to_string(i) + "]\" is not a finite number";
  for (const char* block : {"error_sigma", "error_vs_optimum_sigma"}) {
    if (!j.contains(block)) {
      if (std::string(block) == "error_vs_optimum_sigma") return "field \"error_vs_optimum_sigma\" is missing";
      continue;
    }
    if (!j[block].is_object()) return std::string("field \"") + block + "\" is not an object";
    for (const auto& item : j[block].items())
      if (!finite(item.value()))
        return std::string("field \"") + block + "." + item.key() + "\" is not a finite number";
  }
  return "";
}

}  // namespace

nlohmann::json read_run_record(const fs::path& path, const std::string& scenario,
                               const std::string& label, std::uint64_t seed) {
  nlohmann::json j = read_json_file(path);
  if (std::string problem = run_record_problem(j, scenario, label, seed); !problem.empty())
    throw std::runtime_error(path.string() + ": " + problem);
  return j;
}

std::string run_file_problem(const fs::path& path, const std::string& scenario,
                             const std::string& label, std::uint64_t seed) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return "missing";
  try {
    read_run_record(path, scenario, label, seed);
    return "";
  } catch (const std::exception& e) {
    return e.what();  // truncated, not JSON, a key given twice, unreadable, not this run's
  }
}

namespace {

std::string first_difference(const nlohmann::json& a, const nlohmann::json& b,
                             const std::string& path = "config") {
  if (a.is_number() && b.is_number())  // 0 read back from a file is unsigned, ours signed
    return a.get<double>() == b.get<double>() ? "" : path;
  if (a.type() != b.type()) return path;
  if (a.is_object()) {
    for (const auto& item : a.items()) {
      if (!b.contains(item.key())) return path + "." + item.key();
      const std::string d = first_difference(item.value(), b.at(item.key()), path + "." + item.key());
      if (!d.empty()) return d;
    }
    for (const auto& item : b.items())
      if (!a.contains(item.key())) return path + "." + item.key();
    return "";
  }
  if (a.is_array()) {
    if (a.size() != b.size()) return path + " (length)";
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::string d = first_difference(a[i], b[i], path + "[" + std::to_string(i) + "]");
      if (!d.empty()) return d;
    }
    return "";
  }
  return a == b ? "" : path;
}

// A manifest written before an algorithm gained a parameter lacks that parameter. New
// parameters default to the old behaviour (e.g. DVPIO's shrink_without_gain = 0), so where the
// new config has such a parameter at its default the campaigns are the same: the old config
// gets it added before the two are compared, and such directories can still be resumed and
// merged. A parameter away from its default is a difference as before.
nlohmann::json with_added_defaults(nlohmann::json old_config, const nlohmann::json& new_config) {
  const nlohmann::json* new_algorithms =
      new_config.is_object() && new_config.contains("algorithms") ? &new_config["algorithms"]
                                                                   : nullptr;
  if (!old_config.is_object() || new_algorithms == nullptr || !new_algorithms->is_array() ||
      !old_config.contains("algorithms") || !old_config["algorithms"].is_array() ||
      old_config["algorithms"].size() != new_algorithms->size())
    return old_config;
  for (std::size_t i = 0; i < new_algorithms->size(); ++i) {
    nlohmann::json& old_algorithm = old_config["algorithms"][i];
    const nlohmann::json& new_algorithm = (*new_algorithms)[i];
    if (!old_algorithm.is_object() || !new_algorithm.is_object() ||
        old_algorithm.value("name", "") != new_algorithm.value("name", "") ||
        !old_algorithm.contains("parameters") || !old_algorithm["parameters"].is_object() ||
        !new_algorithm.contains("parameters") || !new_algorithm["parameters"].is_object())
      continue;
    opt::ParameterList defaults;
    try {
      defaults = opt::default_parameters(new_algorithm["name"].get<std::string>());
    } catch (const std::exception&) {
      continue;
    }
    nlohmann::json& old_parameters = old_algorithm["parameters"];
    const nlohmann::json& new_parameters = new_algorithm["parameters"];
    for (const auto& [key, value] : defaults)
      if (!old_parameters.contains(key) && new_parameters.contains(key) &&
          new_parameters[key].is_number() && new_parameters[key].get<double>() == value)
        old_parameters[key] = value;
  }
  return old_config;
}

// Where an existing directory's config first differs from `new_config` ("" when the same
// campaign); what resume, shards, MPI launches and merge compare.
std::string config_difference(const nlohmann::json& old_config, const nlohmann::json& new_config) {
  return first_difference(with_added_defaults(old_config, new_config), new_config);
}

std::vector<EstimatedParameter> estimated_parameters(const CampaignConfig& config) {
  std::vector<EstimatedParameter> params;
  for (const std::string& e : config.estimate) params.push_back(EstimatedParameter::parse(e));
  if (params.empty()) params = EstimatedParameter::paper_four();
  return params;
}

}  // namespace

std::vector<std::uint64_t> seed_range(int n) {
  std::vector<std::uint64_t> seeds;
  for (int i = 1; i <= n; ++i) seeds.push_back(static_cast<std::uint64_t>(i));
  return seeds;
}

nlohmann::json CampaignConfig::to_json() const {
  nlohmann::json j;
  j["name"] = name;
  j["scenarios"] = nlohmann::json::array();
  for (const ScenarioSpec& s : scenarios) {
    nlohmann::json sj;
    sj["name"] = s.name;
    if (!s.preset.empty()) sj["preset"] = s.preset;
    if (!s.data_dir.empty()) sj["data"] = s.data_dir;
    if (s.flight_s) sj["flight_s"] = *s.flight_s;
    if (s.grade) sj["grade"] = *s.grade;
    sj["data_seed"] = s.data_seed;
    sj["set"] = s.set;
    j["scenarios"].push_back(sj);
  }
  j["algorithms"] = nlohmann::json::array();
  for (const AlgorithmSpec& a : algorithms) {
    nlohmann::json params = nlohmann::json::object();
    for (const auto& [k, v] : opt::default_parameters(a.name)) params[k] = v;
    for (const auto& [k, v] : a.parameters) params[k] = v;
    j["algorithms"].push_back({{"label", a.label}, {"name", a.name}, {"parameters", params}});
  }
  j["seeds"] = seeds;
  j["max_iterations"] = max_iterations;
  j["max_evaluations"] = max_evaluations;
  j["alignment"] = insid::to_string(alignment);
  j["estimate"] = nlohmann::json::array();
  for (const EstimatedParameter& p : estimated_parameters(*this))
    j["estimate"].push_back({{"name", p.name}, {"sigma", p.sigma},
                             {"lower_sigma", p.lower_sigma}, {"upper_sigma", p.upper_sigma}});
  j["record_positions_seeds"] = record_positions_seeds;
  j["target_error_sigma"] = target_error_sigma;
  j["target_fitness_gap"] = target_fitness_gap;
  return j;
}

CampaignConfig parse_campaign(const nlohmann::json& j, const std::string& origin) {
  Reader r(j, origin);
  CampaignConfig c;
  if (r.has("name")) c.name = r.string("name");
  for (std::size_t i = 0; i < r.array("scenarios").size(); ++i) {
    const std::string where = origin + ": scenarios[" + std::to_string(i) + "]";
    Reader s(j.at("scenarios")[i], where);
    ScenarioSpec spec;
    spec.name = s.string("name");
    if (s.has("preset")) spec.preset = s.string("preset");
    if (s.has("data")) spec.data_dir = s.string("data");
    if (spec.preset.empty() == spec.data_dir.empty())
      throw std::invalid_argument(where + ": give exactly one of \"preset\" and \"data\"");
    if (s.has("flight_s")) spec.flight_s = s.number("flight_s");
    if (s.has("grade")) spec.grade = s.string("grade");
    if (s.has("data_seed")) spec.data_seed = static_cast<std::uint64_t>(whole(s.number("data_seed"), where + ".data_seed"));
    if (s.has("set")) {
      for (const auto& item : s.at("set").items()) {
        effect_info(item.key());
        if (!item.value().is_number())
          throw std::invalid_argument(where + ".set." + item.key() + " must be a number (SI)");
        spec.set[item.key()] = item.value().get<double>();
      }
    }
    s.finish({"name", "preset", "data", "flight_s", "grade", "data_seed", "set"});
    c.scenarios.push_back(spec);
  }
  for (std::size_t i = 0; i < r.array("algorithms").size(); ++i) {
    const std::string where = origin + ": algorithms[" + std::to_string(i) + "]";
    Reader a(j.at("algorithms")[i], where);
    AlgorithmSpec spec;
    spec.name = a.string("name");
    spec.label = a.has("label") ? a.string("label") : spec.name;
    if (a.has("parameters"))
      for (const auto& item : a.at("parameters").items()) {
        if (!item.value().is_number())
          throw std::invalid_argument(where + ".parameters." + item.key() + " must be a number");
        spec.parameters[item.key()] = item.value().get<double>();
      }
    a.finish({"name", "label", "parameters"});
    c.algorithms.push_back(spec);
  }
  if (r.has("seeds")) {
    const nlohmann::json& s = r.at("seeds");
    if (s.is_number()) {
      const int count = whole(s.get<double>(), origin + ": seeds");
      if (count > 100000)
        throw std::invalid_argument(origin + ": seeds = " + std::to_string(count) +
                                    " is beyond the limit of 100000");
      c.seeds = seed_range(count);
    } else if (s.is_array()) {
      for (std::size_t k = 0; k < s.size(); ++k) {
        const std::string key = origin + ": seeds[" + std::to_string(k) + "]";
        if (!s[k].is_number())
          throw std::invalid_argument(key + " must be a whole number, got " + s[k].dump());
        c.seeds.push_back(static_cast<std::uint64_t>(whole(s[k].get<double>(), key)));
      }
    } else {
      throw std::invalid_argument(origin + ": \"seeds\" must be a count or a list of seeds");
    }
  } else {
    c.seeds = seed_range(31);
  }
  if (r.has("max_iterations")) c.max_iterations = whole(r.number("max_iterations"), origin + ": max_iterations");
  if (r.has("max_evaluations")) c.max_evaluations = whole(r.number("max_evaluations"), origin + ": max_evaluations");
  if (r.has("alignment")) c.alignment = alignment_mode_from_string(r.string("alignment"));
  if (r.has("estimate"))
    for (const auto& e : r.array_of("estimate", "string")) c.estimate.push_back(e.get<std::string>());
  if (r.has("record_positions_seeds")) c.record_positions_seeds = whole(r.number("record_positions_seeds"), origin + ": record_positions_seeds");
  if (r.has("target_error_sigma")) c.target_error_sigma = r.array_of("target_error_sigma", "number").get<std::vector<double>>();
  if (r.has("target_fitness_gap")) c.target_fitness_gap = r.array_of("target_fitness_gap", "number").get<std::vector<double>>();
  r.finish({"name", "scenarios", "algorithms", "seeds", "max_iterations", "max_evaluations",
            "alignment", "estimate", "record_positions_seeds", "target_error_sigma",
            "target_fitness_gap"});
  // Validation with the value named.
  if (c.scenarios.empty()) throw std::invalid_argument(origin + ": no scenario");
  if (c.algorithms.empty()) throw std::invalid_argument(origin + ": no algorithm");
  if (c.seeds.empty()) throw std::invalid_argument(origin + ": no seed");
  constexpr std::size_t kMaxSeeds = 100000;  // each seed is a run file per algorithm
  if (c.seeds.size() > kMaxSeeds)
    throw std::invalid_argument(origin + ": " + std::to_string(c.seeds.size()) +
                                " seeds is beyond the limit of " + std::to_string(kMaxSeeds));
  {
    std::set<std::uint64_t> seen;
    for (std::uint64_t seed : c.seeds)
      if (!seen.insert(seed).second)
        throw std::invalid_argument(origin + ": seed " + std::to_string(seed) +
                                    " is listed twice in \"seeds\"");
  }
  if (c.max_iterations == 0 && c.max_evaluations == 0)
    throw std::invalid_argument(origin + ": give max_iterations or max_evaluations (> 0)");
  std::set<std::string> labels, names;
  for (const AlgorithmSpec& a : c.algorithms) {
    if (!labels.insert(a.label).second)
      throw std::invalid_argument(origin + ": algorithm label '" + a.label + "' used twice");
    opt::RunConfig probe;
    opt::make_optimizer(a.name, opt::Bounds::unit_box(4), probe,
                        opt::ParameterMap(a.parameters.begin(), a.parameters.end()));
  }
  for (const ScenarioSpec& s : c.scenarios)
    if (!names.insert(s.name).second)
      throw std::invalid_argument(origin + ": scenario name '" + s.name + "' used twice");
  estimated_parameters(c);
  return c;
}

std::vector<std::string> preset_campaign_names() {
  return {"paper-fig9", "quick", "paper-plus-baselines"};
}

CampaignConfig preset_campaign(const std::string& name) {
  nlohmann::json j;
  const nlohmann::json table4 = nlohmann::json::array({
      {{"label", "GA"}, {"name", "ga"}},
      {{"label", "PSO"}, {"name", "pso"}},
      {{"label", "PIO"}, {"name", "pio"}},
      {{"label", "DVPIO"}, {"name", "dvpio"}},
  });
  if (name == "paper-fig9") {
    // The paper scenario and the four algorithms with Table 4 settings (DESIGN.md sec. 2).
    j = {{"name", "paper-fig9"},
         {"scenarios", {{{"name", "paper"}, {"preset", "paper"}}}},
         {"algorithms", table4},
         {"seeds", 31},
         {"max_iterations", 40}};
  } else if (name == "quick") {
    // A short rich flight at 10 Hz GNSS: minutes, for a quick look and the tests.
    j = {{"name", "quick"},
         {"scenarios", {{{"name", "rich-short"}, {"preset", "rich"}, {"flight_s", 900}}}},
         {"algorithms", table4},
         {"seeds", 3},
         {"max_iterations", 10}};
  } else if (name == "paper-plus-baselines") {
    // Issue 8: the paper's four and the reference baselines at an equal budget of 400
    // evaluations (the paper's 10 x 40), on the paper and rich scenarios; the EKF-RTS makes one
    // pass plus one evaluation of its estimate (its cost in INS runs is in its parameters).
    nlohmann::json algorithms = table4;
    for (const auto& [label, algo] : std::vector<std::pair<std::string, std::string>>{
             {"CMA-ES", "cmaes"}, {"DE", "de"}, {"compass", "compass"}, {"LM", "lm"},
             {"BOBYQA", "bobyqa"}, {"Nelder-Mead", "neldermead"}, {"EKF-RTS", "ekf-rts"}})
      algorithms.push_back({{"label", label}, {"name", algo}});
    j = {{"name", "paper-plus-baselines"},
         {"scenarios", {{{"name", "paper"}, {"preset", "paper"}}, {{"name", "rich"}, {"preset", "rich"}}}},
         {"algorithms", algorithms},
         {"seeds", 31},
         {"max_iterations", 0},
         {"max_evaluations", 400}};
  } else {
    throw std::invalid_argument("unknown campaign preset '" + name +
                                "'; valid presets: paper-fig9, quick, paper-plus-baselines");
  }
  return parse_campaign(j, "preset " + name);
}

std::shared_ptr<const Dataset> scenario_dataset(const ScenarioSpec& spec) {
  if (!spec.data_dir.empty()) return std::make_shared<const Dataset>(load_dataset(spec.data_dir));
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario(spec.preset);
  if (spec.flight_s) cfg.flight_s = *spec.flight_s;
  if (spec.grade) cfg.noise = scenarios::noise_grade(*spec.grade);
  cfg.seed = spec.data_seed;
  for (const auto& [name, value] : spec.set) add_effect(cfg.injected, name, value);
  return std::make_shared<const Dataset>(scenarios::simulate(cfg));
}

std::string run_file(const std::string& out_dir, const std::string& scenario,
                     const std::string& label, std::uint64_t seed) {
  return (fs::path(out_dir) / "runs" / checked_path_component(scenario, "scenario name") /
          checked_path_component(label, "algorithm label") /
          ("seed_" + std::to_string(seed) + ".json"))
      .string();
}

std::string optimum_file(const std::string& out_dir, const std::string& scenario) {
  return (fs::path(out_dir) / "optimum" / (checked_path_component(scenario, "scenario name") + ".json"))
      .string();
}

Shard Shard::parse(const std::string& text) {
  const auto slash = text.find('/');
  auto number = [&](const std::string& part) {
    if (part.empty() || part.size() > 6 ||
        part.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("--shard '" + text + "': expected i/N with whole numbers, e.g. 2/8");
    return std::stoi(part);
  };
  if (slash == std::string::npos)
    throw std::invalid_argument("--shard '" + text + "': expected i/N, e.g. 2/8");
  Shard shard;
  shard.index = number(text.substr(0, slash));
  shard.count = number(text.substr(slash + 1));
  if (shard.count < 1)
    throw std::invalid_argument("--shard '" + text + "': the number of shards N must be >= 1");
  if (shard.index < 1 || shard.index > shard.count)
    throw std::invalid_argument("--shard '" + text + "': shard index " + std::to_string(shard.index) +
                                " is out of range; it must be in 1.." + std::to_string(shard.count));
  return shard;
}

CampaignConfig config_from_manifest(const nlohmann::json& manifest, const std::string& origin) {
  if (!manifest.is_object() || !manifest.contains("config"))
    throw std::runtime_error(origin + ": not a campaign manifest (no \"config\")");
  if (manifest.value("schema", "") != kManifestSchema)
    throw std::runtime_error(origin + ": schema is '" + manifest.value("schema", "") +
                             "', expected '" + kManifestSchema + "'");
  // The manifest holds the resolved config (CampaignConfig::to_json): the estimated parameters
  // as objects, which parse_campaign takes as NAME:SIGMA:LO:HI specs.
  nlohmann::json j = manifest.at("config");
  nlohmann::json specs = nlohmann::json::array();
  for (const nlohmann::json& p : j.value("estimate", nlohmann::json::array())) {
    std::ostringstream spec;
    spec << std::setprecision(17) << p.at("name").get<std::string>() << ":"
         << p.at("sigma").get<double>() << ":" << p.at("lower_sigma").get<double>() << ":"
         << p.at("upper_sigma").get<double>();
    specs.push_back(spec.str());
  }
  j["estimate"] = specs;
  const CampaignConfig config = parse_campaign(j, origin + " config");
  const nlohmann::json config_json = config.to_json();
  const std::string diff = config_difference(manifest.at("config"), config_json);
  if (!diff.empty())
    throw std::runtime_error(origin + ": the config does not read back identically (first "
                             "difference at " + diff + ")");
  return config;
}

namespace {

// One run of the campaign's run list.
struct RunSpec {
  std::size_t scenario, algorithm;
  std::uint64_t seed;
  std::string path;
};

// The deterministic run list: scenarios, then algorithms, then seeds, in config order. Shards
// and MPI units are positions in this list, so every split does the same runs.
std::vector<RunSpec> run_list(const CampaignConfig& config, const std::string& out_dir) {
  std::vector<RunSpec> runs;
  for (std::size_t s = 0; s < config.scenarios.size(); ++s)
    for (std::size_t a = 0; a < config.algorithms.size(); ++a)
      for (std::uint64_t seed : config.seeds)
        runs.push_back({s, a, seed,
                        run_file(out_dir, config.scenarios[s].name, config.algorithms[a].label, seed)});
  return runs;
}

std::string run_problem(const CampaignConfig& config, const RunSpec& run) {
  return run_file_problem(run.path, config.scenarios[run.scenario].name,
                          config.algorithms[run.algorithm].label, run.seed);
}

// What insid writes at the top of a campaign directory (bench, sweep, the report script).
const OutputKind kCampaignKind{
    "an insid campaign directory",
    {"manifest.json", "runs", "optimum", "summary.json", "sweep.json", "sweep.csv", "report.md",
     "figures", FileLock::kRunLockName}};

// Check out_dir's manifest against `config` (a different campaign is refused unless
// force_new) and write the manifest, under the directory's locks (core/output_dir.h): the
// directory itself gates the check-and-write, `.insid-lock` is held shared by every process
// running this campaign for as long as it runs, and alone by one that starts a new campaign
// there (which therefore fails while another campaign runs). Temporary files left by killed
// processes are removed when no other process runs. Returns the run lock, to hold until the
// campaign ends, and the number of shards the directory is split into (0 when unknown): this
// launch's, or the one recorded by earlier shards of the same campaign.
struct DirectoryClaim {
  std::unique_ptr<FileLock> run_lock;
  int shard_count = 0;
};

// The contents of the scenarios read from data directories (scenario name -> dataset_digest):
// a campaign over data that changed since its runs is a different campaign.
nlohmann::json data_digests(const CampaignConfig& config) {
  nlohmann::json digests = nlohmann::json::object();
  for (const ScenarioSpec& s : config.scenarios)
    if (!s.data_dir.empty()) digests[s.name] = dataset_digest(s.data_dir);
  return digests;
}

DirectoryClaim prepare_directory(const CampaignConfig& config, const RunOptions& options,
                                 int threads) {
  const nlohmann::json config_json = config.to_json();
  const nlohmann::json digests = data_digests(config);
  const fs::path dir(options.out_dir);
  const fs::path manifest_path = dir / "manifest.json";
  std::error_code ec;
  if (!fs::exists(manifest_path, ec) && !options.into_foreign_directory)
    require_own_or_empty(dir, kCampaignKind,
                         "give --force to add the campaign's files and keep the rest");
  fs::create_directories(dir);
  FileLock gate(dir);
  gate.lock(FileLock::Mode::kExclusive);
  DirectoryClaim claim;
  claim.run_lock = std::make_unique<FileLock>(dir / FileLock::kRunLockName);
  const bool alone = claim.run_lock->try_lock(FileLock::Mode::kExclusive);
  if (alone) {
    const int removed = remove_stale_temporaries(dir);
    if (removed > 0 && !options.quiet)
      std::cerr << "insid: removed " << removed << " temporary file(s) left by an interrupted run in "
                << options.out_dir << "\n";
  }
  const std::string in_use =
      options.out_dir + " is in use by another insid process running a campaign there now; "
      "wait for it to finish, or choose another --out";
  int shard_count = options.shard.count;
  if (fs::exists(manifest_path)) {
    nlohmann::json old;
    try {
      old = read_json_file(manifest_path);
    } catch (const std::exception& e) {
      throw std::runtime_error(manifest_path.string() + ": unreadable manifest (" + e.what() +
                               "); use --force-new to start over");
    }
    std::string diff = config_difference(old.value("config", nlohmann::json()), config_json);
    if (diff.empty() && old.contains("data_sha256") && old["data_sha256"] != digests)
      diff = "data_sha256 (a scenario's data files changed since its runs)";
    if (!diff.empty()) {
      if (!options.force_new)
        throw std::runtime_error(
            options.out_dir + " holds results of a different campaign ('" +
            old.value("config", nlohmann::json::object()).value("name", "?") +
            "'; first difference at " + diff +
            "). Use --force-new to discard them, or choose another --out.");
      if (!alone) throw std::runtime_error(in_use);
      fs::remove_all(dir / "runs");
      fs::remove_all(dir / "optimum");
      fs::remove(dir / "summary.json");
    } else if (shard_count == 0) {
      shard_count = old.value("shards", 0);
    }
  } else if (!alone) {
    throw std::runtime_error(in_use);
  }
  nlohmann::json manifest;
  manifest["schema"] = kManifestSchema;
  manifest["build"] = build_info_json();
  manifest["host"] = host_name();
  manifest["cores"] = std::thread::hardware_concurrency();
  manifest["threads"] = threads;
  if (shard_count > 0) manifest["shards"] = shard_count;
  if (options.cluster != nullptr) manifest["mpi_ranks"] = options.cluster->size();
  manifest["config"] = config_json;
  if (!digests.empty()) manifest["data_sha256"] = digests;
  for (const auto& item : options.manifest_extra.items()) manifest[item.key()] = item.value();
  write_file_atomic(manifest_path, manifest.dump(2) + "\n");
  claim.run_lock->lock(FileLock::Mode::kShared);  // a conversion; safe: we hold the gate
  claim.shard_count = shard_count;
  return claim;
}

// What a process does about a scenario's optimum file when it is absent.
enum class OptimumSource {
  kCompute,  // find it and write it (single process, shards, the first MPI rank of a scenario)
  kWait,     // another MPI rank is finding it: wait for its file when a run needs it
};

// Runs lists of runs of one campaign in lock-step waves, preparing scenarios on first use.
class WaveRunner {
 public:
  WaveRunner(const CampaignConfig& config, const RunOptions& options, int threads,
             const std::vector<RunSpec>& runs, int skipped_runs, int runs_to_do)
      : config_(config),
        options_(options),
        threads_(threads),
        runs_(runs),
        mapping_(estimated_parameters(config)),
        states_(config.scenarios.size()),
        skipped_runs_(skipped_runs),
        runs_to_do_(runs_to_do),
        t_start_(std::chrono::steady_clock::now()) {}

  // Run `ids` (positions in the run list), waves of consecutive runs of one scenario of about
  // `wave_target` candidates per round.
  void run(const std::vector<std::size_t>& ids, std::size_t wave_target, OptimumSource source) {
    std::size_t next = 0;
    while (next < ids.size()) {
      const std::size_t scenario = runs_[ids[next]].scenario;
      prepare(scenario, source);
      std::vector<Member> wave;
      std::size_t wave_candidates = 0;
      while (next < ids.size() && runs_[ids[next]].scenario == scenario &&
             (wave.empty() || wave_candidates < wave_target)) {
        add_member(ids[next], wave, wave_candidates);
        ++next;
      }
      run_wave(wave, *states_[scenario].problem);
    }
  }

  int new_runs() const { return done_; }

  // The first failed run's error ("" when none failed).
  std::string first_error() const {
    for (const auto& [id, error] : errors_) {
      try {
        std::rethrow_exception(error);
      } catch (const std::exception& e) {
        return "run " + runs_[id].path + " failed: " + e.what();
      }
    }
    return "";
  }

 private:
  struct ScenarioState {
    std::shared_ptr<const Dataset> dataset;
    std::shared_ptr<const NavigationProblem> navigation;
    std::unique_ptr<InsIdentificationProblem> problem;
    std::optional<ReferenceOptimum> optimum;
  };
  struct Member {
    std::size_t id;  // position in the run list
    std::unique_ptr<opt::Optimizer> optimizer;
    bool finished = false;
  };

  fs::path optimum_path(std::size_t s) const {
    return optimum_file(options_.out_dir, config_.scenarios[s].name);
  }

  std::optional<ReferenceOptimum> read_optimum(std::size_t s) const {
    const fs::path path = optimum_path(s);
    std::error_code ec;
    if (!fs::exists(path, ec)) return std::nullopt;
    try {
      return ReferenceOptimum::from_json(read_json_file(path), mapping_);
    } catch (const std::exception&) {
      return std::nullopt;  // damaged: find it again
    }
  }

  // Dataset, problem and (unless another rank finds it) the data's own optimum of scenario s.
  void prepare(std::size_t s, OptimumSource source) {
    const ScenarioSpec& spec = config_.scenarios[s];
    ScenarioState& st = states_[s];
    if (!st.problem) {
      if (!options_.quiet) std::cerr << "insid bench: preparing scenario " << spec.name << "\n";
      st.dataset = scenario_dataset(spec);
      st.navigation = std::make_shared<const NavigationProblem>(
          st.dataset, NavigationOptions{config_.alignment});
      opt::EvaluatorOptions eval;
      eval.parallelism = opt::Parallelism::kOpenMP;
      eval.num_threads = threads_;
      st.problem = std::make_unique<InsIdentificationProblem>(
          st.navigation, mapping_, FitnessKind::kEq15, eval,
          options_.scalar_reference ? FitnessEvaluator::kScalar : FitnessEvaluator::kBatched);
    }
    if (st.optimum) return;
    st.optimum = read_optimum(s);
    if (st.optimum || source == OptimumSource::kWait) return;
    if (!options_.quiet)
      std::cerr << "insid bench: finding the data's own optimum of " << spec.name << "\n";
    // Deterministic: shards that find it at the same time write the same file (atomically).
    st.optimum = find_reference_optimum(*st.problem);
    nlohmann::json oj = st.optimum->to_json(mapping_);
    oj["scenario"] = spec.name;
    fs::create_directories(optimum_path(s).parent_path());
    write_file_atomic(optimum_path(s), oj.dump(2) + "\n");
  }

  // The optimum of scenario s, waiting for the MPI rank that finds it when it is not there yet.
  const ReferenceOptimum& optimum(std::size_t s) {
    ScenarioState& st = states_[s];
    bool said = false;
    while (!st.optimum) {
      st.optimum = read_optimum(s);
      if (st.optimum) break;
      if (!said && !options_.quiet)
        std::cerr << "insid bench: waiting for another rank to write " << optimum_path(s) << "\n";
      said = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return *st.optimum;
  }

  opt::RunConfig run_config(const RunSpec& run) const {
    opt::RunConfig rc;
    rc.seed = run.seed;
    rc.max_iterations = config_.max_iterations;
    rc.max_evaluations = config_.max_evaluations;
    rc.record_positions = static_cast<int>(
        std::find(config_.seeds.begin(), config_.seeds.end(), run.seed) - config_.seeds.begin()) <
        config_.record_positions_seeds;
    return rc;
  }

  // Kalman-type baselines see the problem and score their own candidates.
  static bool takes_own_step(const opt::Optimizer& optimizer) {
    return dynamic_cast<const opt::ProblemConsumer*>(&optimizer) != nullptr;
  }
  // Least-squares baselines need the residual vectors of their candidates.
  static opt::ResidualConsumer* residual_consumer(opt::Optimizer& optimizer) {
    return dynamic_cast<opt::ResidualConsumer*>(&optimizer);
  }

  void add_member(std::size_t id, std::vector<Member>& wave, std::size_t& wave_candidates) {
    const RunSpec& run = runs_[id];
    const AlgorithmSpec& algo = config_.algorithms[run.algorithm];
    try {
      auto optimizer = opt::make_optimizer(
          algo.name, states_[run.scenario].problem->bounds(), run_config(run),
          opt::ParameterMap(algo.parameters.begin(), algo.parameters.end()));
      if (!takes_own_step(*optimizer) && residual_consumer(*optimizer) == nullptr)
        wave_candidates += optimizer->ask().size();
      wave.push_back({id, std::move(optimizer)});
    } catch (...) {
      errors_[id] = std::current_exception();
    }
  }

  bool failed(std::size_t id) const { return errors_.count(id) > 0; }

  // The candidates of one round that are scored together, and the runs they belong to.
  struct Batch {
    std::vector<Eigen::VectorXd> candidates;
    std::vector<std::pair<Member*, std::size_t>> slices;  // member, its batch size
    void clear() {
      candidates.clear();
      slices.clear();
    }
    void add(Member* member, std::span<const Eigen::VectorXd> xs) {
      candidates.insert(candidates.end(), xs.begin(), xs.end());
      slices.emplace_back(member, xs.size());
    }
  };

  // Scores a round's batch (with the residual vectors when `with_residuals`) and tells each run
  // its slice. When the batch fails, the slices are scored one by one to find the run(s) at
  // fault; the others carry on (their results do not depend on the grouping).
  void score(Batch& batch, const InsIdentificationProblem& problem, bool with_residuals) {
    if (batch.slices.empty()) return;
    const std::size_t n = batch.candidates.size();
    std::vector<double> fitness(n, std::numeric_limits<double>::quiet_NaN());
    std::vector<std::vector<double>> residuals(with_residuals ? n : 0);
    auto evaluate = [&](std::size_t offset, std::size_t size) {
      const auto xs = std::span<const Eigen::VectorXd>(batch.candidates).subspan(offset, size);
      const auto f = std::span<double>(fitness).subspan(offset, size);
      if (with_residuals)
        problem.evaluate_residual_batch(
            xs, std::span<std::vector<double>>(residuals).subspan(offset, size), f);
      else
        problem.evaluate_batch(xs, f);
    };
    try {
      evaluate(0, n);
    } catch (...) {
      std::size_t offset = 0;
      for (const auto& [member, size] : batch.slices) {
        try {
          evaluate(offset, size);
        } catch (...) {
          errors_[member->id] = std::current_exception();
        }
        offset += size;
      }
    }
    std::size_t offset = 0;
    for (const auto& [member, size] : batch.slices) {
      if (!failed(member->id)) {
        try {
          if (with_residuals) {
            const auto first = residuals.begin() + static_cast<std::ptrdiff_t>(offset);
            residual_consumer(*member->optimizer)
                ->set_residuals(std::vector<std::vector<double>>(
                    std::make_move_iterator(first),
                    std::make_move_iterator(first + static_cast<std::ptrdiff_t>(size))));
          }
          member->optimizer->tell(std::span<const double>(fitness).subspan(offset, size));
        } catch (...) {
          errors_[member->id] = std::current_exception();
        }
      }
      offset += size;
    }
  }

  // Runs advance in lock-step (issue 6): the runs of a wave ask for their next batch together,
  // the batches are scored in one evaluate_batch call (the batched kernel spreads groups of
  // candidates over the threads; least-squares runs' residual batches likewise), and each run
  // is told its slice. A run's result depends only
  // on its own fitness values, which do not depend on how candidates are grouped, so results
  // equal separate runs, whatever the waves, shards or ranks. Each run's file is written as
  // soon as the run is done.
  void run_wave(std::vector<Member>& wave, const InsIdentificationProblem& problem) {
    Batch plain, residual;  // fitness-only candidates; candidates whose residuals are needed
    for (;;) {
      // One round: Kalman-type optimizers take their own step (opt::step); the others ask for
      // their next batch, and all fitness-only batches are scored in one evaluate_batch call,
      // all least-squares batches in one evaluate_residual_batch call.
      plain.clear();
      residual.clear();
      for (Member& m : wave) {
        if (m.finished || failed(m.id)) continue;
        try {
          if (takes_own_step(*m.optimizer)) {
            opt::step(*m.optimizer, problem);
            continue;
          }
          Batch& batch = residual_consumer(*m.optimizer) != nullptr ? residual : plain;
          batch.add(&m, m.optimizer->ask());
        } catch (...) {
          errors_[m.id] = std::current_exception();
        }
      }
      score(plain, problem, false);
      score(residual, problem, true);
      bool all_done = true;
      for (Member& m : wave) {
        if (m.finished || failed(m.id)) continue;
        if (!m.optimizer->done()) {
          all_done = false;
          continue;
        }
        m.finished = true;
        try {
          write_run(runs_[m.id], m.optimizer->result());
        } catch (...) {
          errors_[m.id] = std::current_exception();
        }
      }
      if (all_done) break;
    }
  }

  void write_run(const RunSpec& run, const opt::Result& result) {
    const ScenarioSpec& scenario = config_.scenarios[run.scenario];
    const AlgorithmSpec& algo = config_.algorithms[run.algorithm];
    const ReferenceOptimum& opt = optimum(run.scenario);
    nlohmann::json j;
    j["schema"] = kRunSchema;
    j["scenario"] = scenario.name;
    j["algorithm"] = algo.label;
    j["seed"] = run.seed;
    j["parameters"] = nlohmann::json::array();
    for (const EstimatedParameter& p : mapping_.parameters()) j["parameters"].push_back(p.name);
    j["result"] = optimizer_result_json(result, mapping_);
    const Eigen::VectorXd best_sigma = mapping_.to_sigma(result.best_x);
    add_estimate_json(j, mapping_, best_sigma, states_[run.scenario].dataset->meta.injected);
    for (int k = 0; k < mapping_.dimension(); ++k)
      j["error_vs_optimum_sigma"][mapping_.parameters()[static_cast<std::size_t>(k)].name] =
          best_sigma[k] - opt.value_sigma[k];
    j["optimum_fitness"] = opt.fitness;
    j["fitness_gap"] = result.best_f - opt.fitness;
    j["fitness_gap_relative"] = (result.best_f - opt.fitness) / opt.fitness;
    fs::create_directories(fs::path(run.path).parent_path());
    write_file_atomic(run.path, j.dump(1) + "\n");
    const int n_done = ++done_;
    if (!options_.quiet) {
      const double elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start_).count();
      const double eta = elapsed / n_done * (runs_to_do_ - n_done);
      std::cerr << std::fixed << std::setprecision(0);
      if (options_.cluster == nullptr)
        std::cerr << "\rinsid bench: runs " << skipped_runs_ + n_done << "/" << runs_.size()
                  << " (" << scenario.name << " " << algo.label << " seed " << run.seed
                  << "), elapsed " << elapsed << " s, ETA " << eta << " s   ";
      else  // rank 0 sees only its own runs
        std::cerr << "\rinsid bench: rank 0 finished " << n_done << " runs (" << scenario.name
                  << " " << algo.label << " seed " << run.seed << "), elapsed " << elapsed
                  << " s   ";
      std::cerr << std::defaultfloat << std::flush;
    }
  }

  const CampaignConfig& config_;
  const RunOptions& options_;
  const int threads_;
  const std::vector<RunSpec>& runs_;
  const ParameterMapping mapping_;
  std::vector<ScenarioState> states_;
  std::map<std::size_t, std::exception_ptr> errors_;  // by position in the run list
  int done_ = 0;
  const int skipped_runs_, runs_to_do_;
  const std::chrono::steady_clock::time_point t_start_;
};

// Candidates per round a wave aims for: three kernel groups of 16 per thread at least, an
// eighth of the runs to do (at a typical population of 20) at most, so that a killed campaign
// keeps the waves it finished.
std::size_t wave_target(int threads, std::size_t runs_to_do) {
  return std::max<std::size_t>(48 * static_cast<std::size_t>(threads), 20 * runs_to_do / 8);
}

// MPI work units: consecutive runs of one scenario (so that they share a lock-step wave), about
// four per thread to keep the batched kernel's groups full, but small enough that every rank
// gets about four units, so that a rank finishing early can take over work. A unit's first
// number is 1 when the rank that gets it should find its scenario's missing optimum: units are
// dealt in order, so the first unit of a scenario reaches its rank before any other unit of it
// and no rank waits for an optimum that nobody finds. The other numbers are run positions.
std::vector<WorkUnit> make_units(const CampaignConfig& config, const std::vector<RunSpec>& runs,
                                 const std::vector<std::size_t>& pending, int threads, int ranks,
                                 const std::string& out_dir) {
  const std::size_t per_rank = (pending.size() + 4 * static_cast<std::size_t>(ranks) - 1) /
                               (4 * static_cast<std::size_t>(ranks));
  const std::size_t unit_runs =
      std::clamp<std::size_t>(per_rank, 1, 4 * static_cast<std::size_t>(threads));
  std::vector<WorkUnit> units;
  std::set<std::size_t> scenarios_seen;
  for (std::size_t i = 0; i < pending.size();) {
    const std::size_t scenario = runs[pending[i]].scenario;
    const bool first = scenarios_seen.insert(scenario).second;
    const fs::path optimum = optimum_file(out_dir, config.scenarios[scenario].name);
    WorkUnit unit{first && !fs::exists(optimum) ? 1 : 0};
    while (i < pending.size() && runs[pending[i]].scenario == scenario && unit.size() <= unit_runs)
      unit.push_back(static_cast<std::int64_t>(pending[i++]));
    units.push_back(std::move(unit));
  }
  return units;
}

}  // namespace

std::string missing_runs_report(const std::string& out_dir, const CampaignConfig& config,
                                int shard_count) {
  const std::vector<RunSpec> runs = run_list(config, out_dir);
  std::map<int, std::vector<std::string>> missing_by_shard;  // shard 0 when unknown
  std::size_t missing = 0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const std::string problem = run_problem(config, runs[i]);
    if (problem.empty()) continue;
    ++missing;
    const int shard = shard_count > 0 ? static_cast<int>(i % static_cast<std::size_t>(shard_count)) + 1 : 0;
    missing_by_shard[shard].push_back(fs::relative(runs[i].path, out_dir).string() +
                                      (problem == "missing" ? "" : " (damaged: " + problem + ")"));
  }
  if (missing == 0) return "";
  std::ostringstream report;
  report << missing << " of " << runs.size() << " runs missing in " << out_dir;
  for (const auto& [shard, files] : missing_by_shard) {
    report << "\n  ";
    if (shard > 0) report << "shard " << shard << "/" << shard_count << " (" << files.size() << "): ";
    for (std::size_t k = 0; k < files.size(); ++k) {
      if (k == 8) {
        report << " ... and " << files.size() - k << " more";
        break;
      }
      report << (k ? ", " : "") << files[k];
    }
  }
  return report.str();
}

CampaignOutcome run_campaign(const CampaignConfig& config, const RunOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  const fs::path dir(options.out_dir);
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
  Cluster* cluster = options.cluster != nullptr && options.cluster->size() > 1 ? options.cluster : nullptr;
  const bool root = cluster == nullptr || cluster->rank() == 0;
  if (cluster != nullptr && options.shard.active())
    throw std::invalid_argument("--shard cannot be combined with an MPI launch (the ranks share the work already)");
  if (options.force_new && options.shard.active())
    throw std::invalid_argument("--force-new cannot be combined with --shard (it would delete the other shards' runs)");

  // Every path of the campaign first (a config name that cannot be a path is refused before
  // anything is written).
  const std::vector<RunSpec> runs = run_list(config, options.out_dir);
  for (std::size_t s = 0; s < config.scenarios.size(); ++s) optimum_file(options.out_dir, config.scenarios[s].name);

  // The manifest: rank 0 checks and writes it; every rank fails with its message (no rank is
  // left waiting for the others).
  std::string directory_error;
  DirectoryClaim claim;  // held until the campaign returns
  if (root) {
    try {
      claim = prepare_directory(config, options, threads);
    } catch (const std::exception& e) {
      directory_error = e.what();
    }
  }
  if (cluster != nullptr) directory_error = cluster->broadcast(directory_error);
  if (!directory_error.empty() && cluster != nullptr) {
    std::cerr << "insid: error: " << directory_error << std::endl;
    cluster->sum(0);  // every rank has reported before any exits
    throw ReportedError(directory_error);
  }
  if (!directory_error.empty()) throw std::runtime_error(directory_error);
  const int shard_count = claim.shard_count;

  CampaignOutcome outcome;
  outcome.total_runs = static_cast<int>(runs.size());
  outcome.writes_results = root;
  std::vector<std::size_t> pending;  // positions in the run list this invocation should do
  if (root) {
    for (std::size_t i = 0; i < runs.size(); ++i) {
      if (!options.shard.contains(i)) continue;
      const std::string problem = run_problem(config, runs[i]);
      if (problem.empty()) {
        ++outcome.skipped_runs;
        continue;
      }
      if (problem != "missing" && !options.quiet)
        std::cerr << "insid bench: redoing a damaged run file: " << problem << "\n";
      pending.push_back(i);
    }
    if (options.max_new_runs > 0 && pending.size() > static_cast<std::size_t>(options.max_new_runs))
      pending.resize(static_cast<std::size_t>(options.max_new_runs));
  }

  RunOptions rank_options = options;
  if (cluster != nullptr && cluster->rank() != 0) rank_options.quiet = true;  // rank 0 reports
  std::string run_error;
  if (cluster == nullptr) {
    WaveRunner runner(config, rank_options, threads, runs, outcome.skipped_runs,
                      static_cast<int>(pending.size()));
    runner.run(pending, wave_target(threads, pending.size()), OptimumSource::kCompute);
    outcome.new_runs = runner.new_runs();
    run_error = runner.first_error();
  } else {
    outcome.skipped_runs = static_cast<int>(cluster->sum(outcome.skipped_runs));
    const std::vector<WorkUnit> units =
        root ? make_units(config, runs, pending, threads, cluster->size(), options.out_dir)
             : std::vector<WorkUnit>{};
    WaveRunner runner(config, rank_options, threads, runs, outcome.skipped_runs,
                      static_cast<int>(cluster->sum(static_cast<std::int64_t>(pending.size()))));
    cluster->deal(units, [&](const WorkUnit& unit) {
      const std::vector<std::size_t> ids(unit.begin() + 1, unit.end());
      // The unit is one wave: its runs are scored together.
      runner.run(ids, std::numeric_limits<std::size_t>::max(),
                 unit.front() == 1 ? OptimumSource::kCompute : OptimumSource::kWait);
    });
    for (std::int64_t n : cluster->gather(runner.new_runs())) {
      outcome.new_runs_per_rank.push_back(static_cast<int>(n));
      outcome.new_runs += static_cast<int>(n);
    }
    // Every rank learns whether any failed; each reports its own error, or points to the others.
    run_error = runner.first_error();
    if (cluster->sum(run_error.empty() ? 0 : 1) > 0 && run_error.empty())
      run_error = "a run failed on another MPI rank (see its message)";
  }
  if (!options.quiet && root && outcome.new_runs > 0) std::cerr << "\n";
  if (!run_error.empty()) throw std::runtime_error(run_error);

  // Complete when every run is there, whichever process or launch wrote it.
  if (root) {
    outcome.complete = outcome.skipped_runs + outcome.new_runs == outcome.total_runs;
    if (!outcome.complete || options.shard.active() || cluster != nullptr) {
      outcome.missing_report = missing_runs_report(options.out_dir, config, shard_count);
      outcome.complete = outcome.missing_report.empty();
    }
    if (outcome.complete) {
      const nlohmann::json summary = summarize_campaign(options.out_dir, config);
      write_file_atomic(dir / "summary.json", summary.dump(1) + "\n");
    }
  }
  if (cluster != nullptr) {
    outcome.missing_report = cluster->broadcast(outcome.missing_report);
    outcome.complete = outcome.missing_report.empty();
  }
  outcome.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return outcome;
}

}  // namespace insid::campaign
