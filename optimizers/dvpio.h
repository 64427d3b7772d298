// DVPIO: pigeon-inspired optimisation with dimension-vector adaptive mutation (paper Sec. 2.2,
// Eq. 10-14; binding reading of Eq. 14 in docs/design.md sec. 2). Paper Table 4 preset: 10 pigeons,
// 40 iterations, R = 0.05, C = 1, initial d = 0.05 sigma.
//
// Units: d_initial, d_min, d_max and dist_threshold are in the problem's (normalised)
// coordinates. The INS problem maps [-4, 4] sigma to [-1, 1], so the paper's d = 0.05 sigma is
// 0.0125 here (the default); an adapter converts with d_normalised = d_sigma / 4.
// Choices: see dvpio.cc and README.md.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid::opt {

struct DvpioParams {
  static constexpr std::string_view kAlgorithm = "DVPIO";

  int population = 10;           ///< pigeons
  double R = 0.05;               ///< map-and-compass factor (Eq. 8), in [0, 1]
  double C = 1.0;                ///< weight of the pull towards the global best (Eq. 8)
  int per_dimension_rand = 1;    ///< 1: rand drawn per dimension; 0: one rand per pigeon
  double dist_threshold = 0.05;  ///< premature when Dist (Eq. 10) < this (problem units)
  double d_initial = 0.0125;     ///< initial d_jp = d_jn (problem units; 0.05 sigma in the INS box)
  double d_min = 1e-6;           ///< lower clamp of d (problem units)
  double d_max = 0.5;            ///< upper clamp of d (problem units)
  /// 0 (default): Eq. 14 exactly as docs/design.md sec. 2 reads it. 1: an insid variant, not the
  /// paper's: when neither probe of dimension j beats the X_gbest they were placed around, both
  /// d of j are halved and j's T history restarts, instead of Eq. 14 (which compares the two
  /// probes only, and can lock d at (d_max/2, d_max): optimizers/README.md).
  int shrink_without_gain = 0;

  static std::span<const ParameterField<DvpioParams>> fields();
  std::string validate() const;
  ParameterList list() const { return list_parameters(*this); }
  ParameterInfoList info() const { return list_parameter_info(*this); }
  void set(std::string_view name, double value) { set_parameter(*this, name, value); }
  static DvpioParams from_map(const ParameterMap& overrides) {
    return parameters_from_map<DvpioParams>(overrides);
  }
};

class DvpioOptimizer final : public Optimizer {
 public:
  /// Throws std::invalid_argument on invalid params, bounds or config.
  DvpioOptimizer(const Bounds& bounds, const RunConfig& config, const DvpioParams& params = {});

  ParameterList parameters() const override { return params_.list(); }
  const DvpioParams& params() const { return params_; }
  bool premature() const { return premature_; }
  /// Dimensions probed per premature iteration: min(n, population / 2).
  int dimensions_per_iteration() const;

 protected:
  void propose(std::vector<Eigen::VectorXd>& batch) override;
  void accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) override;
  void annotate(IterationRecord& record) const override;
  std::string phase() const override;

 private:
  void propose_premature();
  void adapt_d(int dim, int older, int newer);

  DvpioParams params_;
  std::vector<Eigen::VectorXd> x_, v_;
  std::vector<double> f_;       ///< fitness of the current positions
  bool premature_ = false;      ///< sticky once Dist < dist_threshold
  Eigen::VectorXd d_positive_;  ///< d_jp for the next probes
  Eigen::VectorXd d_negative_;  ///< d_jn for the next probes
  std::vector<int> last_flag_;  ///< T_j of the last probe of dim j; 0 = never probed
  int probe_cursor_ = 0;        ///< first dim probed next (when population < 2n)
  // The batch being evaluated:
  bool batch_premature_ = false;
  Eigen::VectorXd batch_d_positive_, batch_d_negative_;
  std::vector<int> batch_flags_;                      ///< T_j of this batch, 0 = not probed
  std::vector<int> probe_positive_, probe_negative_;  ///< pigeon probing +d / -d per dim, or -1
  double batch_gbest_f_ = 0.0;                        ///< f(X_gbest) the probes were placed around
};

}  // namespace insid::opt
