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
#include <iostream>
#include <limits>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "optimizers/registry.h"
#include "scenarios/scenario.h"

namespace insid::campaign {
namespace fs = std::filesystem;

namespace {

constexpr const char* kManifestSchema = "insid-campaign/1";
constexpr const char* kRunSchema = "insid-run/1";

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

nlohmann::json read_json_file(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  nlohmann::json j;
  in >> j;
  return j;
}

// A finished run file is valid when it parses and names this run.
bool run_file_is_complete(const fs::path& path, const std::string& scenario,
                          const std::string& label, std::uint64_t seed) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  try {
    const nlohmann::json j = read_json_file(path);
    return j.value("schema", "") == kRunSchema && j.value("scenario", "") == scenario &&
           j.value("algorithm", "") == label && j.value("seed", std::uint64_t{0}) == seed &&
           j.contains("result");
  } catch (const std::exception&) {
    return false;  // truncated or damaged: redo
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
  for (std::size_t i = 0; i < r.at("scenarios").size(); ++i) {
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
  for (std::size_t i = 0; i < r.at("algorithms").size(); ++i) {
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
      c.seeds = seed_range(whole(s.get<double>(), origin + ": seeds"));
    } else if (s.is_array()) {
      for (const auto& v : s) c.seeds.push_back(static_cast<std::uint64_t>(whole(v.get<double>(), origin + ": seeds[]")));
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
    for (const auto& e : r.at("estimate")) c.estimate.push_back(e.get<std::string>());
  if (r.has("record_positions_seeds")) c.record_positions_seeds = whole(r.number("record_positions_seeds"), origin + ": record_positions_seeds");
  if (r.has("target_error_sigma")) c.target_error_sigma = r.at("target_error_sigma").get<std::vector<double>>();
  if (r.has("target_fitness_gap")) c.target_fitness_gap = r.at("target_fitness_gap").get<std::vector<double>>();
  r.finish({"name", "scenarios", "algorithms", "seeds", "max_iterations", "max_evaluations",
            "alignment", "estimate", "record_positions_seeds", "target_error_sigma",
            "target_fitness_gap"});
  // Validation with the value named.
  if (c.scenarios.empty()) throw std::invalid_argument(origin + ": no scenario");
  if (c.algorithms.empty()) throw std::invalid_argument(origin + ": no algorithm");
  if (c.seeds.empty()) throw std::invalid_argument(origin + ": no seed");
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
  return (fs::path(out_dir) / "runs" / scenario / label / ("seed_" + std::to_string(seed) + ".json"))
      .string();
}

CampaignOutcome run_campaign(const CampaignConfig& config, const RunOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  const fs::path dir(options.out_dir);
  fs::create_directories(dir);
  const nlohmann::json config_json = config.to_json();
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();

  // Manifest: a different campaign's directory is refused unless --force-new.
  const fs::path manifest_path = dir / "manifest.json";
  if (fs::exists(manifest_path)) {
    nlohmann::json old;
    try {
      old = read_json_file(manifest_path);
    } catch (const std::exception& e) {
      throw std::runtime_error(manifest_path.string() + ": unreadable manifest (" + e.what() +
                               "); use --force-new to start over");
    }
    const std::string diff = first_difference(old.value("config", nlohmann::json()), config_json);
    if (!diff.empty()) {
      if (!options.force_new)
        throw std::runtime_error(
            options.out_dir + " holds results of a different campaign ('" +
            old.value("config", nlohmann::json::object()).value("name", "?") +
            "'; first difference at " + diff +
            "). Use --force-new to discard them, or choose another --out.");
      fs::remove_all(dir / "runs");
      fs::remove_all(dir / "optimum");
      fs::remove(dir / "summary.json");
    }
  }
  nlohmann::json manifest;
  manifest["schema"] = kManifestSchema;
  manifest["build"] = build_info_json();
  manifest["host"] = host_name();
  manifest["cores"] = std::thread::hardware_concurrency();
  manifest["threads"] = threads;
  manifest["config"] = config_json;
  write_file_atomic(manifest_path, manifest.dump(2) + "\n");

  // Scenarios: datasets, navigation problems, the data's own optimum (stored once).
  const ParameterMapping mapping(estimated_parameters(config));
  struct ScenarioState {
    std::shared_ptr<const Dataset> dataset;
    std::shared_ptr<const NavigationProblem> navigation;
    std::unique_ptr<InsIdentificationProblem> problem;
    ReferenceOptimum optimum;
  };
  std::vector<ScenarioState> states(config.scenarios.size());

  struct RunSpec {
    std::size_t scenario, algorithm;
    std::uint64_t seed;
    std::string path;
  };
  std::vector<RunSpec> pending;
  CampaignOutcome outcome;
  for (std::size_t s = 0; s < config.scenarios.size(); ++s)
    for (std::size_t a = 0; a < config.algorithms.size(); ++a)
      for (std::uint64_t seed : config.seeds) {
        ++outcome.total_runs;
        const std::string path =
            run_file(options.out_dir, config.scenarios[s].name, config.algorithms[a].label, seed);
        if (run_file_is_complete(path, config.scenarios[s].name, config.algorithms[a].label, seed))
          ++outcome.skipped_runs;
        else
          pending.push_back({s, a, seed, path});
      }
  std::set<std::size_t> needed;
  for (const RunSpec& r : pending) needed.insert(r.scenario);
  for (std::size_t s : needed) {
    const ScenarioSpec& spec = config.scenarios[s];
    if (!options.quiet) std::cerr << "insid bench: preparing scenario " << spec.name << "\n";
    ScenarioState& st = states[s];
    st.dataset = scenario_dataset(spec);
    st.navigation = std::make_shared<const NavigationProblem>(
        st.dataset, NavigationOptions{config.alignment});
    opt::EvaluatorOptions eval;
    eval.parallelism = opt::Parallelism::kOpenMP;
    eval.num_threads = threads;
    st.problem = std::make_unique<InsIdentificationProblem>(
        st.navigation, mapping, FitnessKind::kEq15, eval,
        options.scalar_reference ? FitnessEvaluator::kScalar : FitnessEvaluator::kBatched);
    const fs::path opt_path = dir / "optimum" / (spec.name + ".json");
    bool have = false;
    if (fs::exists(opt_path)) {
      try {
        const nlohmann::json oj = read_json_file(opt_path);
        st.optimum.fitness = oj.at("fitness").get<double>();
        st.optimum.evaluations = oj.at("evaluations").get<std::int64_t>();
        st.optimum.starts = oj.at("starts").get<int>();
        st.optimum.value_sigma.resize(mapping.dimension());
        for (int k = 0; k < mapping.dimension(); ++k)
          st.optimum.value_sigma[k] =
              oj.at("estimate_sigma").at(mapping.parameters()[static_cast<std::size_t>(k)].name);
        have = true;
      } catch (const std::exception&) {
        have = false;
      }
    }
    if (!have) {
      if (!options.quiet)
        std::cerr << "insid bench: finding the data's own optimum of " << spec.name << "\n";
      st.optimum = find_reference_optimum(*st.problem);
      nlohmann::json oj = st.optimum.to_json(mapping);
      oj["scenario"] = spec.name;
      fs::create_directories(opt_path.parent_path());
      write_file_atomic(opt_path, oj.dump(2) + "\n");
    }
  }

  if (options.max_new_runs > 0 && pending.size() > static_cast<std::size_t>(options.max_new_runs))
    pending.resize(static_cast<std::size_t>(options.max_new_runs));

  // Runs advance in lock-step (issue 6): the runs of a wave (consecutive pending runs of one
  // scenario) ask for their next batch together, the batches are scored in one evaluate_batch
  // call (the batched kernel spreads groups of candidates over the threads), and each run is
  // told its slice. A run's result depends only on its own fitness values, which do not depend
  // on how candidates are grouped, so results equal separate runs. A wave holds enough runs to
  // fill every thread with several kernel groups per round, and at most about an eighth of the
  // campaign, so that a killed campaign keeps the waves it finished; each run's file is written
  // as soon as the run is done.
  std::mutex progress_mutex;
  int done = 0;
  std::vector<std::exception_ptr> errors(pending.size());
  const auto t_runs = std::chrono::steady_clock::now();
  const int n_pending = static_cast<int>(pending.size());

  auto run_config = [&](const RunSpec& run) {
    opt::RunConfig rc;
    rc.seed = run.seed;
    rc.max_iterations = config.max_iterations;
    rc.max_evaluations = config.max_evaluations;
    rc.record_positions = static_cast<int>(
        std::find(config.seeds.begin(), config.seeds.end(), run.seed) - config.seeds.begin()) <
        config.record_positions_seeds;
    return rc;
  };
  auto write_run = [&](const RunSpec& run, const opt::Result& result) {
    const ScenarioSpec& scenario = config.scenarios[run.scenario];
    const AlgorithmSpec& algo = config.algorithms[run.algorithm];
    const ScenarioState& st = states[run.scenario];
    nlohmann::json j;
    j["schema"] = kRunSchema;
    j["scenario"] = scenario.name;
    j["algorithm"] = algo.label;
    j["seed"] = run.seed;
    j["parameters"] = nlohmann::json::array();
    for (const EstimatedParameter& p : mapping.parameters()) j["parameters"].push_back(p.name);
    j["result"] = optimizer_result_json(result, mapping);
    const Eigen::VectorXd best_sigma = mapping.to_sigma(result.best_x);
    add_estimate_json(j, mapping, best_sigma, st.dataset->meta.injected);
    for (int k = 0; k < mapping.dimension(); ++k)
      j["error_vs_optimum_sigma"][mapping.parameters()[static_cast<std::size_t>(k)].name] =
          best_sigma[k] - st.optimum.value_sigma[k];
    j["optimum_fitness"] = st.optimum.fitness;
    j["fitness_gap"] = result.best_f - st.optimum.fitness;
    j["fitness_gap_relative"] = (result.best_f - st.optimum.fitness) / st.optimum.fitness;
    fs::create_directories(fs::path(run.path).parent_path());
    write_file_atomic(run.path, j.dump(1) + "\n");
    const int n_done = ++done;
    if (!options.quiet) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      const double elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_runs).count();
      const double eta = elapsed / n_done * (n_pending - n_done);
      std::cerr << "\rinsid bench: runs " << outcome.skipped_runs + n_done << "/"
                << outcome.total_runs << " (" << scenario.name << " " << algo.label << " seed "
                << run.seed << "), elapsed " << std::fixed << std::setprecision(0) << elapsed
                << " s, ETA " << eta << " s   " << std::defaultfloat << std::flush;
    }
  };

  // Candidates per round a wave aims for: three kernel groups of 16 per thread at least, an
  // eighth of the campaign (at a typical population of 20) at most.
  const std::size_t wave_target = std::max<std::size_t>(48 * static_cast<std::size_t>(threads),
                                                        20 * pending.size() / 8);

  struct Member {
    std::size_t index;  // into pending
    std::unique_ptr<opt::Optimizer> optimizer;
    bool finished = false;
  };
  std::size_t next = 0;
  while (next < pending.size()) {
    // Form a wave.
    std::vector<Member> wave;
    std::size_t wave_candidates = 0;
    const std::size_t scenario = pending[next].scenario;
    while (next < pending.size() && pending[next].scenario == scenario &&
           (wave.empty() || wave_candidates < wave_target)) {
      const RunSpec& run = pending[next];
      const AlgorithmSpec& algo = config.algorithms[run.algorithm];
      try {
        auto optimizer = opt::make_optimizer(
            algo.name, states[scenario].problem->bounds(), run_config(run),
            opt::ParameterMap(algo.parameters.begin(), algo.parameters.end()));
        if (dynamic_cast<opt::ResidualConsumer*>(optimizer.get()) == nullptr &&
            dynamic_cast<opt::ProblemConsumer*>(optimizer.get()) == nullptr)
          wave_candidates += optimizer->ask().size();
        wave.push_back({next, std::move(optimizer)});
      } catch (...) {
        errors[next] = std::current_exception();
      }
      ++next;
    }
    const InsIdentificationProblem& problem = *states[scenario].problem;

    std::vector<Eigen::VectorXd> candidates;
    std::vector<double> fitness;
    std::vector<std::pair<Member*, std::size_t>> slices;  // member, batch size
    for (;;) {
      // One round: optimizers that need residuals or the problem take their own step (as in
      // opt::run_together); the others share one batch.
      candidates.clear();
      slices.clear();
      for (Member& m : wave) {
        if (m.finished || errors[m.index]) continue;
        try {
          if (dynamic_cast<opt::ResidualConsumer*>(m.optimizer.get()) != nullptr ||
              dynamic_cast<opt::ProblemConsumer*>(m.optimizer.get()) != nullptr) {
            opt::step(*m.optimizer, problem);
            continue;
          }
          const std::span<const Eigen::VectorXd> batch = m.optimizer->ask();
          candidates.insert(candidates.end(), batch.begin(), batch.end());
          slices.emplace_back(&m, batch.size());
        } catch (...) {
          errors[m.index] = std::current_exception();
        }
      }
      if (!slices.empty()) {
        fitness.assign(candidates.size(), std::numeric_limits<double>::quiet_NaN());
        try {
          problem.evaluate_batch(candidates, fitness);
        } catch (...) {
          // Find the run(s) whose candidates fail by scoring the slices one by one; the others
          // carry on (their results do not depend on the grouping).
          std::size_t offset = 0;
          for (const auto& [member, size] : slices) {
            try {
              problem.evaluate_batch(std::span<const Eigen::VectorXd>(candidates).subspan(offset, size),
                                     std::span<double>(fitness).subspan(offset, size));
            } catch (...) {
              errors[member->index] = std::current_exception();
            }
            offset += size;
          }
        }
        std::size_t offset = 0;
        for (const auto& [member, size] : slices) {
          if (!errors[member->index]) {
            try {
              member->optimizer->tell(std::span<const double>(fitness).subspan(offset, size));
            } catch (...) {
              errors[member->index] = std::current_exception();
            }
          }
          offset += size;
        }
      }
      bool all_done = true;
      for (Member& m : wave) {
        if (m.finished || errors[m.index]) continue;
        if (!m.optimizer->done()) {
          all_done = false;
          continue;
        }
        m.finished = true;
        try {
          write_run(pending[m.index], m.optimizer->result());
        } catch (...) {
          errors[m.index] = std::current_exception();
        }
      }
      if (all_done) break;
    }
  }
  if (!options.quiet && n_pending > 0) std::cerr << "\n";
  for (std::size_t i = 0; i < errors.size(); ++i) {
    if (!errors[i]) continue;
    try {
      std::rethrow_exception(errors[i]);
    } catch (const std::exception& e) {
      throw std::runtime_error("run " + pending[i].path + " failed: " + e.what());
    }
  }
  outcome.new_runs = done;
  outcome.complete = outcome.skipped_runs + outcome.new_runs == outcome.total_runs;
  if (outcome.complete) {
    const nlohmann::json summary = summarize_campaign(options.out_dir, config);
    write_file_atomic(dir / "summary.json", summary.dump(1) + "\n");
  }
  outcome.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return outcome;
}

}  // namespace insid::campaign
