// Real-coded genetic algorithm: tournament selection, SBX crossover, polynomial mutation,
// elitist replacement (paper Table 4 preset: 20 individuals, 40 generations, crossover
// probability 0.5, mutation probability 0.2). Choices: see ga.cc and README.md.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

struct GaParams {
  static constexpr std::string_view kAlgorithm = "GA";

  int population = 20;          ///< individuals (= offspring per generation)
  double crossover_prob = 0.5;  ///< probability that a parent pair is crossed (SBX)
  double mutation_prob = 0.2;   ///< probability that a gene (coordinate) is mutated
  int tournament_size = 2;      ///< individuals drawn per tournament
  double sbx_eta = 15.0;        ///< SBX distribution index (larger: children nearer parents)
  double mutation_eta = 20.0;   ///< polynomial-mutation distribution index
  int elite_count = 1;          ///< best parents that compete with the offspring

  static std::span<const ParameterField<GaParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static GaParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<GaParams>(overrides);
  }
};

class GaOptimizer final : public Optimizer {
 public:
  /// Throws std::invalid_argument on invalid params, bounds or config.
  GaOptimizer(const Bounds& bounds, const RunConfig& config, const GaParams& params = {});

  ParameterList parameters() const override { return params_.list(); }
  const GaParams& params() const { return params_; }

 protected:
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  std::string phase() const override { return iteration() == 0 ? "initial" : "generation"; }

 private:
  int tournament();
  void crossover(Eigen::VectorXd& a, Eigen::VectorXd& b);
  void mutate(Eigen::VectorXd& x);

  GaParams params_;
  std::vector<Eigen::VectorXd> population_;
  std::vector<double> fitness_;
};

}  // namespace insid::opt
