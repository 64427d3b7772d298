// Particle swarm optimisation (Kennedy & Eberhart 1995; inertia weight: Shi & Eberhart 1998).
//
// Choices the paper leaves open (also in optimizers/README.md):
//  - Topology: global best. The social term pulls towards the run's best-so-far point.
//  - Update, per particle i and dimension j, with r1, r2 ~ U[0, 1) drawn per dimension:
//      v_ij <- w v_ij + c1 r1 (p_ij - x_ij) + c2 r2 (g_j - x_ij),   x_ij <- x_ij + v_ij.
//  - Velocity clamp |v_ij| <= v_max_fraction * (upper_j - lower_j) (default 0.2). The paper's
//    w = 0.8, c1 = c2 = 2 lie outside the swarm's convergence region (Poli 2009: needs
//    c1 + c2 < 24 (1 - w^2) / (7 - 5 w) = 2.88), so without the clamp the swarm explodes.
//  - Initial positions uniform in the box; initial velocities uniform in [-v_max, v_max].
//  - Bounds: a coordinate leaving the box is clamped to the face and that velocity component
//    set to zero.
//  - Personal best replaced only on strict improvement.
//  - Draw order: initial positions (particle-major), then initial velocities; each update
//    draws r1, r2 for particle 0 dimension 0, 0/1, ..., then particle 1, ...
#include "optimizers/pso.h"

#include <algorithm>
#include <stdexcept>

namespace insid::opt {

std::span<const ParameterField<PsoParams>> PsoParams::fields() {
  static const ParameterField<PsoParams> kFields[] = {
      {"population", &PsoParams::population, "number of particles"},
      {"w", &PsoParams::w, "inertia weight"},
      {"c1", &PsoParams::c1, "cognitive acceleration (towards the personal best)"},
      {"c2", &PsoParams::c2, "social acceleration (towards the global best)"},
      {"v_max_fraction", &PsoParams::v_max_fraction,
       "velocity clamp per dimension as a fraction of the box width"},
  };
  return kFields;
}

std::string PsoParams::validate() const {
  for (std::string error :
       {check_at_least(kAlgorithm, "population", population, 1),
        check_range(kAlgorithm, "w", w, 0.0, 1.0), check_range(kAlgorithm, "c1", c1, 0.0, 4.0),
        check_range(kAlgorithm, "c2", c2, 0.0, 4.0),
        check_positive(kAlgorithm, "v_max_fraction", v_max_fraction),
        check_range(kAlgorithm, "v_max_fraction", v_max_fraction, 0.0, 1.0)}) {
    if (!error.empty()) return error;
  }
  return {};
}

PsoOptimizer::PsoOptimizer(const Bounds& bounds, const RunConfig& config, const PsoParams& params)
    : Optimizer("PSO", bounds, config), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
  check_initial_positions(params_.population);
  v_max_ = params_.v_max_fraction * this->bounds().width();
}

void PsoOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  const Bounds& box = bounds();
  const int n = box.dimension();
  if (iteration() == 0) {
    x_ = initial_population(params_.population);
    v_.assign(x_.size(), Eigen::VectorXd(n));
    for (Eigen::VectorXd& v : v_) {
      for (int j = 0; j < n; ++j) v[j] = rng().uniform(-v_max_[j], v_max_[j]);
    }
  } else {
    const Eigen::VectorXd& global_best = best_x();
    for (std::size_t i = 0; i < x_.size(); ++i) {
      Eigen::VectorXd& x = x_[i];
      Eigen::VectorXd& v = v_[i];
      for (int j = 0; j < n; ++j) {
        const double r1 = rng().uniform();
        const double r2 = rng().uniform();
        v[j] = params_.w * v[j] + params_.c1 * r1 * (personal_best_x_[i][j] - x[j]) +
               params_.c2 * r2 * (global_best[j] - x[j]);
        v[j] = std::clamp(v[j], -v_max_[j], v_max_[j]);
        x[j] += v[j];
        if (x[j] < box.lower[j] || x[j] > box.upper[j]) {
          x[j] = std::clamp(x[j], box.lower[j], box.upper[j]);
          v[j] = 0.0;
        }
      }
    }
  }
  batch = x_;
}

void PsoOptimizer::accept(std::span<const Eigen::VectorXd> batch, std::span<const double> fitness) {
  if (personal_best_x_.empty()) {
    personal_best_x_.assign(batch.begin(), batch.end());
    personal_best_f_.assign(fitness.begin(), fitness.end());
    return;
  }
  for (std::size_t i = 0; i < batch.size(); ++i) {
    if (fitness[i] < personal_best_f_[i]) {
      personal_best_f_[i] = fitness[i];
      personal_best_x_[i] = batch[i];
    }
  }
}

}  // namespace insid::opt
