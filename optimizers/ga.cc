// Real-coded genetic algorithm.
//
// Choices the paper leaves open (also in optimizers/README.md):
//  - Generation: N offspring are made (N = population) and all evaluated, so a generation is
//    one batch of N and "20 individuals, 40 generations" is 800 evaluations.
//  - Selection: tournament of tournament_size (default 2) individuals drawn uniformly with
//    replacement; the fittest wins (ties: the first drawn).
//  - Crossover: each parent pair is crossed with probability crossover_prob (0.5), otherwise
//    copied. Simulated binary crossover (Deb & Agrawal 1995), every coordinate, distribution
//    index sbx_eta = 15: u ~ U[0,1), beta = (2u)^(1/(eta+1)) for u <= 0.5, else
//    (1 / (2 (1 - u)))^(1/(eta+1)); children 0.5 ((1 +- beta) a + (1 -+ beta) b).
//  - Mutation: each coordinate of each child mutated with probability mutation_prob (0.2) by
//    polynomial mutation (Deb & Goyal 1996), index mutation_eta = 20: u ~ U[0,1),
//    delta = (2u)^(1/(eta+1)) - 1 for u < 0.5, else 1 - (2 (1 - u))^(1/(eta+1));
//    x += delta * (upper - lower).
//  - Bounds: children are clamped to the box after crossover and mutation.
//  - Elitism: the elite_count (1) best parents join the offspring and the best N of the union
//    form the next population (an elite is kept unless N offspring beat it); no re-evaluation.
//  - Odd N: the last pair contributes only its first child.
//  - Draw order per pair: two tournaments, the crossover coin, SBX u per coordinate (if
//    crossed), then per child and coordinate the mutation coin and, if mutated, its u.
#include "optimizers/ga.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace insid::opt {

std::span<const ParameterField<GaParams>> GaParams::fields() {
  static const ParameterField<GaParams> kFields[] = {
      {"population", &GaParams::population, "individuals (= offspring per generation)"},
      {"crossover_prob", &GaParams::crossover_prob, "probability that a parent pair is crossed"},
      {"mutation_prob", &GaParams::mutation_prob, "probability that a coordinate is mutated"},
      {"tournament_size", &GaParams::tournament_size, "individuals drawn per tournament"},
      {"sbx_eta", &GaParams::sbx_eta, "SBX crossover distribution index"},
      {"mutation_eta", &GaParams::mutation_eta, "polynomial mutation distribution index"},
      {"elite_count", &GaParams::elite_count, "best parents competing with the offspring"},
  };
  return kFields;
}

std::string GaParams::validate() const {
  for (std::string error :
       {check_at_least(kAlgorithm, "population", population, 2),
        check_range(kAlgorithm, "crossover_prob", crossover_prob, 0.0, 1.0),
        check_range(kAlgorithm, "mutation_prob", mutation_prob, 0.0, 1.0),
        check_range(kAlgorithm, "tournament_size", tournament_size, 1.0, population),
        check_range(kAlgorithm, "sbx_eta", sbx_eta, 0.0, 1000.0),
        check_range(kAlgorithm, "mutation_eta", mutation_eta, 0.0, 1000.0),
        check_range(kAlgorithm, "elite_count", elite_count, 0.0, population)}) {
    if (!error.empty()) return error;
  }
  return {};
}

GaOptimizer::GaOptimizer(const Bounds& bounds, const RunConfig& config, const GaParams& params)
    : Optimizer("GA", bounds, config), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
  check_initial_positions(params_.population);
}

int GaOptimizer::tournament() {
  const auto size = static_cast<std::uint64_t>(population_.size());
  int winner = static_cast<int>(rng().below(size));
  for (int k = 1; k < params_.tournament_size; ++k) {
    const int challenger = static_cast<int>(rng().below(size));
    if (fitness_[challenger] < fitness_[winner]) winner = challenger;
  }
  return winner;
}

void GaOptimizer::crossover(Eigen::VectorXd& a, Eigen::VectorXd& b) {
  const double exponent = 1.0 / (params_.sbx_eta + 1.0);
  for (Eigen::Index j = 0; j < a.size(); ++j) {
    const double u = rng().uniform();
    const double beta =
        u <= 0.5 ? std::pow(2.0 * u, exponent) : std::pow(1.0 / (2.0 * (1.0 - u)), exponent);
    const double aj = a[j];
    const double bj = b[j];
    a[j] = 0.5 * ((1.0 + beta) * aj + (1.0 - beta) * bj);
    b[j] = 0.5 * ((1.0 - beta) * aj + (1.0 + beta) * bj);
  }
}

void GaOptimizer::mutate(Eigen::VectorXd& x) {
  const double exponent = 1.0 / (params_.mutation_eta + 1.0);
  const Bounds& box = bounds();
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    if (rng().uniform() >= params_.mutation_prob) continue;
    const double u = rng().uniform();
    const double delta =
        u < 0.5 ? std::pow(2.0 * u, exponent) - 1.0 : 1.0 - std::pow(2.0 * (1.0 - u), exponent);
    x[j] += delta * (box.upper[j] - box.lower[j]);
  }
}

void GaOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  if (iteration() == 0) {
    batch = initial_population(params_.population);
    return;
  }
  const auto size = static_cast<std::size_t>(params_.population);
  while (batch.size() < size) {
    Eigen::VectorXd a = population_[tournament()];
    Eigen::VectorXd b = population_[tournament()];
    if (rng().uniform() < params_.crossover_prob) crossover(a, b);
    mutate(a);
    mutate(b);
    batch.push_back(clamp(a));
    if (batch.size() < size) batch.push_back(clamp(b));
  }
}

void GaOptimizer::accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) {
  if (population_.empty()) {
    population_.assign(batch.begin(), batch.end());
    fitness_.assign(fitness.begin(), fitness.end());
    return;
  }
  // Elitist replacement: the elite_count best parents compete with the offspring.
  std::vector<int> parent_order(population_.size());
  std::iota(parent_order.begin(), parent_order.end(), 0);
  std::stable_sort(parent_order.begin(), parent_order.end(),
                   [&](int a, int b) { return fitness_[a] < fitness_[b]; });

  std::vector<Eigen::VectorXd> pool;
  std::vector<double> pool_f;
  for (int e = 0; e < params_.elite_count; ++e) {
    pool.push_back(population_[parent_order[e]]);
    pool_f.push_back(fitness_[parent_order[e]]);
  }
  pool.insert(pool.end(), batch.begin(), batch.end());
  pool_f.insert(pool_f.end(), fitness.begin(), fitness.end());

  std::vector<int> order(pool.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return pool_f[a] < pool_f[b]; });
  order.resize(static_cast<std::size_t>(params_.population));
  population_.clear();
  fitness_.clear();
  for (int k : order) {
    population_.push_back(pool[k]);
    fitness_.push_back(pool_f[k]);
  }
}

}  // namespace insid::opt
