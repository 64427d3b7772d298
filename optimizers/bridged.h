// Base of the baselines that wrap a blocking, sequential solver library (NLopt, Ceres, pagmo's
// compass search) through a SolverBridge (solver_bridge.h): every objective call of the solver
// becomes one batch of the ask/tell loop (one point, or 1 + n for a Levenberg-Marquardt Jacobian).
//
// Starts and restarts. The solver starts at config().initial_positions[0] when given, else at a
// uniform point of the box drawn from the run's seed. When it stops on its own (converged) while
// the budget lasts, it restarts from a new uniform point; the best-so-far is kept, so a fixed
// budget is always spent and the trace shows when the solution was reached.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"
#include "optimizers/random.h"
#include "optimizers/solver_bridge.h"

namespace insid::opt::detail {

class BridgedOptimizer : public Optimizer {
 public:
  ~BridgedOptimizer() override { stop_solver(); }

 protected:
  BridgedOptimizer(std::string name, Bounds bounds, RunConfig config)
      : Optimizer(std::move(name), std::move(bounds), std::move(config)),
        start_rng_(this->config().seed ^ 0x5eed5eed5eed5eedULL) {
    check_initial_positions(1);
    bridge_ = std::make_unique<SolverBridge>([this](SolverBridge& bridge) { solve(bridge); });
  }

  /// Runs in the worker thread: start the solver at start_point(), loop over restarts, return
  /// (or stop the solver) once a request() has returned false.
  virtual void solve(SolverBridge& bridge) = 0;

  /// Derived destructors call this first (the worker uses their members).
  void stop_solver() { bridge_.reset(); }

  /// Start point of the k-th start (worker thread).
  Eigen::VectorXd start_point() {
    ++starts_;
    if (starts_ == 1 && !config().initial_positions.empty()) return config().initial_positions[0];
    Eigen::VectorXd x(bounds().dimension());
    for (int j = 0; j < x.size(); ++j)
      x[j] = start_rng_.uniform(bounds().lower[j], bounds().upper[j]);
    return x;
  }
  int starts() const { return starts_; }

  void propose(std::vector<Eigen::VectorXd>& batch) override {
    batch = bridge_->wait_request();
    phase_ = iteration() == 0 ? "initial" : bridge_->label();
  }
  void accept(std::span<const Eigen::VectorXd>, std::span<const double> fitness) override {
    bridge_->deliver(std::vector<double>(fitness.begin(), fitness.end()),
                     std::move(pending_residuals_));
    pending_residuals_.clear();
  }
  std::string phase() const override { return phase_; }

  std::vector<std::vector<double>> pending_residuals_;  ///< set by ResidualConsumer subclasses

 private:
  Rng start_rng_;
  int starts_ = 0;
  std::string phase_;
  std::unique_ptr<SolverBridge> bridge_;
};

}  // namespace insid::opt::detail
