#include "optimizers/registry.h"

#include <algorithm>
#include <mutex>
#include <stdexcept>
#include <utility>

#include "optimizers/ceres_lm.h"
#include "optimizers/dvpio.h"
#include "optimizers/external.h"
#include "optimizers/ga.h"
#include "optimizers/nlopt_algorithms.h"
#include "optimizers/pagmo_algorithms.h"
#include "optimizers/pio.h"
#include "optimizers/pso.h"

namespace insid::opt {
namespace {

using Family = AlgorithmTraits::Family;

bool is_prefix(std::string_view name) { return !name.empty() && name.back() == ':'; }

// An entry whose optimizer is made as OptimizerT(bounds, config, ParamsT::from_map(overrides)).
template <class OptimizerT, class ParamsT>
AlgorithmEntry entry(std::string name, AlgorithmTraits traits) {
  return {std::move(name),
          [](std::string_view, const Bounds& bounds, const RunConfig& config,
             const ParameterMap& overrides) -> std::unique_ptr<Optimizer> {
            return std::make_unique<OptimizerT>(bounds, config, ParamsT::from_map(overrides));
          },
          [] { return ParamsT{}.info(); }, std::move(traits)};
}

AlgorithmEntry nlopt_entry(std::string name, NloptOptimizer::Method method,
                           std::string description) {
  return {std::move(name),
          [method](std::string_view, const Bounds& bounds, const RunConfig& config,
                   const ParameterMap& overrides) -> std::unique_ptr<Optimizer> {
            return std::make_unique<NloptOptimizer>(method, bounds, config,
                                                    NloptParams::from_map(overrides));
          },
          [] { return NloptParams{}.info(); },
          {.family = Family::kBaseline, .description = std::move(description)}};
}

// The built-in algorithms, in the order algorithm_names() lists them. Every one of them draws
// from the run's seed: the population-based ones their population, the single-start ones
// (compass, lm, bobyqa, neldermead) their start points, the first one too unless the run gives
// initial positions (detail::BridgedOptimizer::start_point).
std::vector<AlgorithmEntry> built_in() {
  std::vector<AlgorithmEntry> table;
  table.push_back(entry<GaOptimizer, GaParams>(
      "ga", {.family = Family::kPaper, .description = "genetic algorithm (the paper's GA)"}));
  table.push_back(entry<PsoOptimizer, PsoParams>(
      "pso", {.family = Family::kPaper, .description = "particle swarm optimization"}));
  table.push_back(entry<PioOptimizer, PioParams>(
      "pio", {.family = Family::kPaper, .description = "pigeon-inspired optimization"}));
  table.push_back(entry<DvpioOptimizer, DvpioParams>(
      "dvpio", {.family = Family::kPaper,
                .description = "dynamic-variation pigeon-inspired optimization (the paper's)"}));
  table.push_back(entry<CmaesOptimizer, CmaesParams>(
      "cmaes", {.family = Family::kBaseline, .description = "CMA-ES (pagmo2)"}));
  table.push_back(entry<DeOptimizer, DeParams>(
      "de", {.family = Family::kBaseline, .description = "differential evolution (pagmo2)"}));
  table.push_back(entry<CompassOptimizer, CompassParams>(
      "compass", {.family = Family::kBaseline,
                  .description = "compass search with random restarts (pagmo2)"}));
  table.push_back(entry<LmOptimizer, LmParams>(
      "lm", {.family = Family::kBaseline,
             .least_squares = true,
             .needs_residuals = true,
             .description = "Levenberg-Marquardt on the residual vector (Ceres)"}));
  table.push_back(nlopt_entry("bobyqa", NloptOptimizer::Method::kBobyqa,
                              "BOBYQA trust-region quadratic models (NLopt)"));
  table.push_back(nlopt_entry("neldermead", NloptOptimizer::Method::kNelderMead,
                              "Nelder-Mead simplex (NLopt)"));
  // The external program is handed the run's seed; whether it uses it is its own affair.
  table.push_back(
      {std::string(kExternalPrefix),
       [](std::string_view name, const Bounds& bounds, const RunConfig& config,
          const ParameterMap& overrides) -> std::unique_ptr<Optimizer> {
         return std::make_unique<ExternalOptimizer>(
             std::string(name.substr(kExternalPrefix.size())), bounds, config,
             ExternalParams::from_map(overrides));
       },
       [] { return ExternalParams{}.info(); },
       {.family = Family::kExternal,
        .description = "a program speaking the JSON-lines protocol (optimizers/README.md)"}});
  return table;
}

struct Table {
  std::mutex mutex;
  std::vector<AlgorithmEntry> entries = built_in();
  std::size_t built_in_count = entries.size();
};

// Constructed on first use, so that registrars running during static initialisation in other
// translation units find it ready.
Table& table() {
  static Table t;
  return t;
}

// The entry named `algorithm` exactly, else the prefix entry it starts with; nullptr if none.
// Call with the table's mutex held.
const AlgorithmEntry* find_locked(const Table& t, std::string_view algorithm) {
  for (const AlgorithmEntry& e : t.entries)
    if (!is_prefix(e.name) && e.name == algorithm) return &e;
  for (const AlgorithmEntry& e : t.entries)
    if (is_prefix(e.name) && algorithm.substr(0, e.name.size()) == e.name) return &e;
  return nullptr;
}

std::vector<std::string> names_where(const std::function<bool(const AlgorithmEntry&)>& keep) {
  Table& t = table();
  std::lock_guard<std::mutex> lock(t.mutex);
  std::vector<std::string> names;
  for (const AlgorithmEntry& e : t.entries)
    if (!is_prefix(e.name) && keep(e)) names.push_back(e.name);
  return names;
}

[[noreturn]] void unknown_algorithm(std::string_view algorithm) {
  std::string names;
  for (const std::string& name : algorithm_names()) names += (names.empty() ? "" : ", ") + name;
  throw std::invalid_argument("unknown optimizer '" + std::string(algorithm) +
                              "'; valid optimizers: " + names);
}

}  // namespace

std::vector<std::string> algorithm_names() {
  return names_where([](const AlgorithmEntry&) { return true; });
}

std::vector<std::string> paper_algorithm_names() {
  return names_where([](const AlgorithmEntry& e) { return e.traits.family == Family::kPaper; });
}

std::vector<std::string> baseline_algorithm_names() {
  return names_where([](const AlgorithmEntry& e) { return e.traits.family == Family::kBaseline; });
}

AlgorithmEntry algorithm_entry(std::string_view algorithm) {
  {
    Table& t = table();
    std::lock_guard<std::mutex> lock(t.mutex);
    if (const AlgorithmEntry* e = find_locked(t, algorithm)) return *e;
  }
  unknown_algorithm(algorithm);
}

AlgorithmTraits algorithm_traits(std::string_view algorithm) {
  return algorithm_entry(algorithm).traits;
}

bool register_algorithm(AlgorithmEntry entry) {
  if (entry.name.empty() || is_prefix(entry.name))
    throw std::invalid_argument("register_algorithm: '" + entry.name +
                                "' is not a name an algorithm can be registered under");
  if (!entry.make || !entry.parameters)
    throw std::invalid_argument("register_algorithm: '" + entry.name +
                                "' needs a factory and its parameters");
  Table& t = table();
  std::lock_guard<std::mutex> lock(t.mutex);
  const auto it = std::find_if(t.entries.begin(), t.entries.end(),
                               [&](const AlgorithmEntry& e) { return e.name == entry.name; });
  if (it == t.entries.end()) {
    t.entries.push_back(std::move(entry));
  } else if (static_cast<std::size_t>(it - t.entries.begin()) < t.built_in_count) {
    throw std::invalid_argument("register_algorithm: '" + entry.name + "' is a built-in algorithm");
  } else {
    *it = std::move(entry);
  }
  return true;
}

std::unique_ptr<Optimizer> make_optimizer(std::string_view algorithm, const Bounds& bounds,
                                          const RunConfig& config, const ParameterMap& overrides) {
  return algorithm_entry(algorithm).make(algorithm, bounds, config, overrides);
}

ParameterList default_parameters(std::string_view algorithm) {
  ParameterList list;
  for (ParameterInfo& p : parameter_info(algorithm)) list.emplace_back(std::move(p.name), p.value);
  return list;
}

ParameterInfoList parameter_info(std::string_view algorithm) {
  return algorithm_entry(algorithm).parameters();
}

Result optimize(std::string_view algorithm, const Problem& problem, const RunConfig& config,
                const ParameterMap& overrides) {
  const std::unique_ptr<Optimizer> optimizer =
      make_optimizer(algorithm, problem.bounds(), config, overrides);
  return run(*optimizer, problem);
}

}  // namespace insid::opt
