#include "bench/campaign_config.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include "base/json_object.h"
#include "base/json_reader.h"
#include "base/number_text.h"
#include "base/output_dir.h"
#include "identification/grade.h"
#include "identification/identify.h"
#include "optimizers/registry.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid::campaign {
namespace fs = std::filesystem;

namespace {

// A name read by its own parser, which names the valid ones; its error at the field's path.
template <typename Parse>
auto parsed_name(const JsonObject& r, std::string_view key, Parse parse) {
  const std::string name = r.string(key);
  try {
    return parse(name);
  } catch (const std::invalid_argument& e) {
    r.fail(key, e.what());
  }
}

std::string first_difference(const nlohmann::json& a, const nlohmann::json& b,
                             const std::string& path = "config") {
  if (a.is_number() && b.is_number())  // 0 read back from a file is unsigned, ours signed
    return a.get<double>() == b.get<double>() ? "" : path;
  if (a.type() != b.type()) return path;
  if (a.is_object()) {
    for (const auto& item : a.items()) {
      if (!b.contains(item.key())) return path + "." + item.key();
      const std::string d =
          first_difference(item.value(), b.at(item.key()), path + "." + item.key());
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
// merged. A parameter away from its default is a difference.
//
// A config written before issue 47 lacks "fitness": it was searched on the exact kernel.
nlohmann::json with_added_defaults(nlohmann::json old_config, const nlohmann::json& new_config) {
  if (old_config.is_object() && !old_config.contains("fitness")) old_config["fitness"] = "exact";
  const nlohmann::json* new_algorithms = new_config.is_object() && new_config.contains("algorithms")
                                             ? &new_config["algorithms"]
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

}  // namespace

std::string config_difference(const nlohmann::json& old_config, const nlohmann::json& new_config) {
  return first_difference(with_added_defaults(old_config, new_config), new_config);
}

NavigationOptions CampaignConfig::navigation_options() const {
  NavigationOptions options;
  options.alignment = alignment;
  options.window_s = window_s;
  if (initial_attitude) {
    options.initial_attitude.mode = *initial_attitude;
    options.initial_attitude.heading_deg = heading_deg;
    options.initial_attitude.heading_source = heading_source;
  }
  // The feasibility check meets the estimated gyro biases' box: identify's one rule
  // (identification/identify.h), with or without an "initial_attitude" key.
  options.initial_attitude.gyro_bias_allowance_rad_s =
      gyro_bias_allowance_rad_s(estimated_parameters(*this));
  return options;
}

std::vector<EstimatedParameter> estimated_parameters(const CampaignConfig& config) {
  // identify's default set and sigmas (identification/identify.h); without an estimation_grade
  // the catalogue's, which are nav's.
  return identify_parameters(sensor_grade(config.estimation_grade.value_or("nav")),
                             config.estimate);
}

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
  if (initial_attitude) j["initial_attitude"] = insid::to_string(*initial_attitude);
  if (heading_deg) j["heading_deg"] = *heading_deg;
  if (heading_source) j["heading_source"] = insid::to_string(*heading_source);
  if (window_s != 0.0) j["window_s"] = window_s;
  if (estimation_grade) j["estimation_grade"] = *estimation_grade;
  j["estimate"] = nlohmann::json::array();
  for (const EstimatedParameter& p : estimated_parameters(*this))
    j["estimate"].push_back({{"name", p.name},
                             {"sigma", p.sigma},
                             {"lower_sigma", p.lower_sigma},
                             {"upper_sigma", p.upper_sigma}});
  j["record_positions_seeds"] = record_positions_seeds;
  // Only when set to something else than the default: manifests written before the key existed
  // still match on resume.
  if (uncertainty_replicas != 0) j["uncertainty_replicas"] = uncertainty_replicas;
  j["fitness"] = insid::to_string(search_fitness);
  j["target_error_sigma"] = target_error_sigma;
  j["target_fitness_gap"] = target_fitness_gap;
  return j;
}

CampaignConfig parse_campaign(const nlohmann::json& j, const std::string& origin) {
  // Counts and seeds: whole numbers up to 1e9 (a seed is a run file per algorithm; validate()
  // bounds the number of seeds further).
  constexpr std::int64_t kMaxWhole = 1000000000;
  const JsonObject r = JsonObject::document(
      j, origin,
      {"name", "scenarios", "algorithms", "seeds", "max_iterations", "max_evaluations", "alignment",
       "initial_attitude", "heading_deg", "heading_source", "window_s", "estimation_grade",
       "estimate", "record_positions_seeds", "target_error_sigma", "target_fitness_gap",
       "uncertainty_replicas", "fitness"});
  CampaignConfig c;
  c.name = r.string("name", c.name);
  const JsonArray scenarios = r.array("scenarios");
  for (std::size_t i = 0; i < scenarios.size(); ++i) {
    const JsonObject s =
        scenarios[i].object({"name", "preset", "data", "flight_s", "grade", "data_seed", "set"});
    ScenarioSpec spec;
    spec.name = s.string("name");
    spec.preset = s.string("preset", "");
    spec.data_dir = s.string("data", "");
    if (spec.preset.empty() == spec.data_dir.empty())
      s.fail("give exactly one of \"preset\" and \"data\"");
    if (s.has("flight_s")) spec.flight_s = s.field("flight_s").number();
    if (s.has("grade")) spec.grade = s.string("grade");
    if (s.has("data_seed"))
      spec.data_seed = static_cast<std::uint64_t>(s.field("data_seed").integer(0, kMaxWhole));
    if (s.has("set")) {
      const JsonObject set = s.field("set").map();
      for (const auto& item : set.value().items()) {
        try {
          effect_info(item.key());
        } catch (const std::invalid_argument& e) {
          set.fail(item.key(), e.what());
        }
        spec.set[item.key()] = set.field(item.key()).number();  // SI
      }
    }
    c.scenarios.push_back(spec);
  }
  const JsonArray algorithms = r.array("algorithms");
  for (std::size_t i = 0; i < algorithms.size(); ++i) {
    const JsonObject a = algorithms[i].object({"name", "label", "parameters"});
    AlgorithmSpec spec;
    spec.name = a.string("name");
    spec.label = a.string("label", spec.name);
    if (a.has("parameters")) {
      const JsonObject parameters = a.field("parameters").map();
      for (const auto& item : parameters.value().items())
        spec.parameters[item.key()] = parameters.field(item.key()).number();
    }
    c.algorithms.push_back(spec);
  }
  if (const std::optional<JsonField> seeds = r.optional("seeds")) {
    if (seeds->value().is_number()) {
      const std::int64_t count = seeds->integer(0, kMaxWhole);
      if (count > 100000)
        seeds->fail(std::to_string(count) + " seeds is beyond the limit of 100000");
      c.seeds = seed_range(static_cast<int>(count));
    } else if (seeds->value().is_array()) {
      const JsonArray list = seeds->array();
      for (std::size_t k = 0; k < list.size(); ++k)
        c.seeds.push_back(static_cast<std::uint64_t>(list[k].integer(0, kMaxWhole)));
    } else {
      seeds->fail("expected a count or a list of seeds, found " +
                  describe_json_value(seeds->value()));
    }
  } else {
    c.seeds = seed_range(31);
  }
  if (r.has("max_iterations"))
    c.max_iterations = static_cast<int>(r.field("max_iterations").integer(0, kMaxWhole));
  if (r.has("max_evaluations"))
    c.max_evaluations = static_cast<int>(r.field("max_evaluations").integer(0, kMaxWhole));
  // Each name is read by its own parser (the old name "align" of gyrocompass among them).
  if (r.has("alignment")) c.alignment = parsed_name(r, "alignment", alignment_mode_from_string);
  if (r.has("initial_attitude"))
    c.initial_attitude = parsed_name(r, "initial_attitude", initial_attitude_mode_from_string);
  if (r.has("heading_deg")) c.heading_deg = r.field("heading_deg").number();
  if (r.has("heading_source"))
    c.heading_source = parsed_name(r, "heading_source", heading_source_from_string);
  if (r.has("window_s")) c.window_s = r.field("window_s").number();
  if (r.has("estimation_grade")) c.estimation_grade = r.string("estimation_grade");
  if (r.has("estimate")) c.estimate = r.array("estimate").strings();
  if (r.has("record_positions_seeds"))
    c.record_positions_seeds =
        static_cast<int>(r.field("record_positions_seeds").integer(0, kMaxWhole));
  if (r.has("uncertainty_replicas"))
    c.uncertainty_replicas =
        static_cast<int>(r.field("uncertainty_replicas").integer(0, kMaxWhole));
  if (r.has("fitness"))
    c.search_fitness = parsed_name(
        r, "fitness", [](const std::string& text) { return kSearchFitnessNames.value(text); });
  if (r.has("target_error_sigma")) c.target_error_sigma = r.array("target_error_sigma").numbers();
  if (r.has("target_fitness_gap")) c.target_fitness_gap = r.array("target_fitness_gap").numbers();
  c.validate(origin);
  return c;
}

CampaignConfig read_campaign_file(const std::string& path) {
  nlohmann::json j;
  try {
    j = read_json_file(path);
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(e.what());  // the file's content is the argument
  }
  return parse_campaign(j, path);
}

void CampaignConfig::validate(const std::string& origin) const {
  if (scenarios.empty()) throw std::invalid_argument(origin + ": no scenario");
  if (algorithms.empty()) throw std::invalid_argument(origin + ": no algorithm");
  if (seeds.empty()) throw std::invalid_argument(origin + ": no seed");
  constexpr std::size_t kMaxSeeds = 100000;  // each seed is a run file per algorithm
  if (seeds.size() > kMaxSeeds)
    throw std::invalid_argument(origin + ": " + std::to_string(seeds.size()) +
                                " seeds is beyond the limit of " + std::to_string(kMaxSeeds));
  // Every run is a file under runs/ and a record the summary holds in memory: a campaign
  // beyond a million runs is refused at once, with its count, before anything runs.
  constexpr double kMaxRuns = 1e6;
  const double runs = static_cast<double>(scenarios.size()) *
                      static_cast<double>(algorithms.size()) * static_cast<double>(seeds.size());
  if (runs > kMaxRuns)
    throw std::invalid_argument(
        origin + ": " + number_text(runs, 12) + " runs (" + std::to_string(scenarios.size()) +
        " scenarios x " + std::to_string(algorithms.size()) + " algorithms x " +
        std::to_string(seeds.size()) +
        " seeds) is beyond the limit of 1000000 runs per campaign (each is a run file and a "
        "record in memory); split it into several campaigns");
  {
    std::set<std::uint64_t> seen;
    for (std::uint64_t seed : seeds)
      if (!seen.insert(seed).second)
        throw std::invalid_argument(origin + ": seed " + std::to_string(seed) +
                                    " is listed twice in \"seeds\"");
  }
  if (heading_deg && initial_attitude != InitialAttitudeMode::kLevelHeading)
    throw std::invalid_argument(origin + ": heading_deg " + opt::format_number(*heading_deg) +
                                " is given but initial_attitude is " +
                                (initial_attitude ? insid::to_string(*initial_attitude)
                                                  : std::string("absent (gyrocompass)")) +
                                "; heading_deg goes with \"initial_attitude\": \"level+heading\"");
  if (heading_deg && !(std::isfinite(*heading_deg) && std::abs(*heading_deg) <= 360.0))
    throw std::invalid_argument(origin +
                                ": heading_deg must be a finite angle in [-360, 360] "
                                "deg, got " +
                                opt::format_number(*heading_deg));
  if (heading_source) {
    // The same rules as the command line (InitialAttitudeOptions::validate).
    InitialAttitudeOptions o;
    o.mode = initial_attitude.value_or(InitialAttitudeMode::kGyrocompass);
    o.heading_deg = heading_deg;
    o.heading_source = heading_source;
    if (const std::string why = o.validate(); !why.empty())
      throw std::invalid_argument(origin + ": heading_source " + insid::to_string(*heading_source) +
                                  ": " + why);
  }
  if (estimation_grade) {
    const std::vector<std::string> grades = sensor_grade_names();
    if (std::find(grades.begin(), grades.end(), *estimation_grade) == grades.end())
      throw std::invalid_argument(origin + ": estimation_grade '" + *estimation_grade +
                                  "': expected nav, tactical or mems (the grade of the "
                                  "estimation, identification/grade.h; the simulated noise is "
                                  "scenarios[].grade)");
  }
  if (const std::string why = navigation_options().validate(); !why.empty())
    throw std::invalid_argument(origin + ": " + why);
  if (std::string error = navigation_options().initial_attitude.validate(); !error.empty())
    throw std::invalid_argument(origin + ": " + error);
  if (max_iterations < 0)
    throw std::invalid_argument(origin + ": max_iterations must be >= 0, got " +
                                std::to_string(max_iterations));
  if (max_evaluations < 0)
    throw std::invalid_argument(origin + ": max_evaluations must be >= 0, got " +
                                std::to_string(max_evaluations));
  if (max_iterations == 0 && max_evaluations == 0)
    throw std::invalid_argument(origin + ": give max_iterations or max_evaluations (> 0)");
  if (record_positions_seeds < 0)
    throw std::invalid_argument(origin + ": record_positions_seeds must be >= 0, got " +
                                std::to_string(record_positions_seeds));
  if (uncertainty_replicas < 0 || (uncertainty_replicas > 0 && uncertainty_replicas < 10) ||
      uncertainty_replicas > 100000)
    throw std::invalid_argument(origin +
                                ": uncertainty_replicas must be 0 (none) or in [10, "
                                "100000] (UncertaintyOptions.replicas), got " +
                                std::to_string(uncertainty_replicas));
  std::set<std::string> labels, names;
  for (const AlgorithmSpec& a : algorithms) {
    if (!labels.insert(a.label).second)
      throw std::invalid_argument(origin + ": algorithm label '" + a.label + "' used twice");
    opt::RunConfig probe;
    opt::make_optimizer(a.name, opt::Bounds::unit_box(4), probe,
                        opt::ParameterMap(a.parameters.begin(), a.parameters.end()));
  }
  for (std::size_t i = 0; i < scenarios.size(); ++i) {
    const ScenarioSpec& s = scenarios[i];
    const std::string where = origin + ": scenarios[" + std::to_string(i) + "]";
    if (!names.insert(s.name).second)
      throw std::invalid_argument(origin + ": scenario name '" + s.name + "' used twice");
    if (s.preset.empty() == s.data_dir.empty())
      throw std::invalid_argument(where + ": give exactly one of \"preset\" and \"data\"");
    if (s.flight_s && !(*s.flight_s > 0.0 && std::isfinite(*s.flight_s)))
      throw std::invalid_argument(where + ".flight_s must be a positive number of seconds, got " +
                                  std::to_string(*s.flight_s));
    // Unknown names fail here, before a directory is written, not when the scenario is made.
    try {
      if (!s.preset.empty()) scenarios::preset_scenario(s.preset);
      if (s.grade) scenarios::noise_grade(*s.grade);
    } catch (const std::exception& e) {
      throw std::invalid_argument(where + ": " + e.what());
    }
  }
  estimated_parameters(*this);
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
    // The paper scenario and the four algorithms with Table 4 settings (docs/design.md sec. 2).
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
    // The paper's four and the reference baselines at an equal budget of 400
    // evaluations (the paper's 10 x 40), on the paper and rich scenarios; the EKF-RTS makes one
    // pass plus one evaluation of its estimate (its cost in INS runs is in its parameters).
    nlohmann::json algorithms = table4;
    for (const auto& [label, algo] :
         std::vector<std::pair<std::string, std::string>>{{"CMA-ES", "cmaes"},
                                                          {"DE", "de"},
                                                          {"compass", "compass"},
                                                          {"LM", "lm"},
                                                          {"BOBYQA", "bobyqa"},
                                                          {"Nelder-Mead", "neldermead"},
                                                          {"EKF-RTS", "ekf-rts"}})
      algorithms.push_back({{"label", label}, {"name", algo}});
    j = {{"name", "paper-plus-baselines"},
         {"scenarios",
          {{{"name", "paper"}, {"preset", "paper"}}, {{"name", "rich"}, {"preset", "rich"}}}},
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

std::string run_file(const std::string& out_dir, const std::string& scenario,
                     const std::string& label, std::uint64_t seed) {
  return (fs::path(out_dir) / "runs" / checked_path_component(scenario, "scenario name") /
          checked_path_component(label, "algorithm label") /
          ("seed_" + std::to_string(seed) + ".json"))
      .string();
}

std::string optimum_file(const std::string& out_dir, const std::string& scenario) {
  return (fs::path(out_dir) / "optimum" /
          (checked_path_component(scenario, "scenario name") + ".json"))
      .string();
}

Shard Shard::parse(const std::string& text) {
  const auto slash = text.find('/');
  auto number = [&](const std::string& part) {
    if (part.empty() || part.size() > 6 ||
        part.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("--shard '" + text +
                                  "': expected i/N with whole numbers, e.g. 2/8");
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
    throw std::invalid_argument(
        "--shard '" + text + "': shard index " + std::to_string(shard.index) +
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
  // Written before issue 47: searched on the exact kernel (with_added_defaults).
  if (!j.contains("fitness")) j["fitness"] = "exact";
  const CampaignConfig config = parse_campaign(j, origin + " config");
  const nlohmann::json config_json = config.to_json();
  const std::string diff = config_difference(manifest.at("config"), config_json);
  if (!diff.empty())
    throw std::runtime_error(origin +
                             ": the config does not read back identically (first "
                             "difference at " +
                             diff + ")");
  return config;
}

}  // namespace insid::campaign
