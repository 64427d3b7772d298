// Pigeon-inspired optimisation (Duan & Qiao 2014; paper Eq. 8-9): the map-and-compass operator,
// then the landmark operator (population halved each iteration, moving towards the weighted
// centre). Paper Table 4 preset: 10 pigeons, 40 iterations, R = 0.05, C = 1.
// Choices: see pio.cc and README.md.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"
#include "optimizers/random.h"

namespace insid::opt {

struct PioParams {
  static constexpr std::string_view kAlgorithm = "PIO";

  int population = 10;              ///< pigeons
  double R = 0.05;                  ///< map-and-compass factor (Eq. 8), in [0, 1]
  double C = 1.0;                   ///< weight of the pull towards the global best (Eq. 8)
  double landmark_fraction = 0.25;  ///< share of the planned iterations for the landmark operator
  int landmark_min_population = 2;  ///< the landmark halving stops at this many pigeons
  int per_dimension_rand = 1;       ///< 1: rand drawn per dimension; 0: one rand per pigeon

  static std::span<const ParameterField<PioParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static PioParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<PioParams>(overrides);
  }
};

/// One map-and-compass step for one pigeon, Nc = `nc` (1 for the first update):
///   Eq. 8: V <- V exp(-R Nc) + C rand (X_gbest - X);   Eq. 9: X <- X + V.
/// rand is per dimension or one draw per pigeon. A coordinate leaving the box is clamped to the
/// face and that velocity component set to zero.
void map_compass_move(const Bounds& bounds, double R, double C, int nc, bool per_dimension_rand,
                      const Eigen::VectorXd& x_gbest, Eigen::VectorXd& x, Eigen::VectorXd& v,
                      Rng& rng);

class PioOptimizer final : public Optimizer {
 public:
  /// Throws std::invalid_argument on invalid params, bounds or config.
  PioOptimizer(const Bounds& bounds, const RunConfig& config, const PioParams& params = {});

  ParameterList parameters() const override { return params_.list(); }
  const PioParams& params() const { return params_; }

 protected:
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  std::string phase() const override { return phase_; }

 private:
  void landmark_step();

  PioParams params_;
  /// Iterations (batches, the initial one included) of the map-and-compass phase.
  int map_compass_iterations_ = 0;
  std::string phase_;
  std::vector<Eigen::VectorXd> x_, v_;
  std::vector<double> f_;  ///< fitness of the current positions
};

}  // namespace insid::opt
