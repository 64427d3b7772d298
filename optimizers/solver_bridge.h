// Runs a blocking solver library (NLopt, Ceres, pagmo's compass search: each calls back into an
// objective and returns only when it has finished) as a coroutine of the ask/tell loop.
//
// The solver runs in a worker thread. Its objective calls request(points), which hands the points
// to the optimizer's thread and blocks until their values are delivered; the optimizer's
// propose() waits for the next request. Exactly one of the two threads runs at any time, so a
// run is as deterministic as the solver itself: the same seed and the same fitness values give
// the same requests, whatever the thread timing. Destroying the bridge while the solver waits
// makes request() return false (the adapter then stops its solver: NLopt forced stop, Ceres
// abort, an exception through pagmo) and joins the thread.
// Internal to the baseline optimizers (not part of the public interface).
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/Core>

namespace insid::opt::detail {

class SolverBridge {
 public:
  /// Thrown by adapters through a solver that does not support a clean stop (caught by the
  /// bridge).
  struct Aborted {};

  /// `body` runs in the worker thread on the first wait_request(). It must not return while the
  /// run goes on (restart the solver in a loop); it returns (or throws Aborted) once request()
  /// has returned false.
  using Body = std::function<void(SolverBridge&)>;
  explicit SolverBridge(Body body) : body_(std::move(body)) {}
  ~SolverBridge();
  SolverBridge(const SolverBridge&) = delete;
  SolverBridge& operator=(const SolverBridge&) = delete;

  // --- worker side ---
  /// Hands `points` over and blocks until their values arrive. Returns false when the bridge is
  /// being destroyed (nothing was evaluated; the solver must stop).
  /// `label` names the operator for the history (e.g. "jacobian").
  bool request(std::vector<Eigen::VectorXd> points, std::vector<double>& fitness,
               std::vector<std::vector<double>>* residuals = nullptr, std::string label = {});
  bool aborting() const;

  // --- optimizer side ---
  /// Starts the worker if needed and waits for its next request; returns the requested points
  /// (non-empty). Rethrows an exception that ended the worker; throws std::logic_error when the
  /// body returned without being asked to stop.
  const std::vector<Eigen::VectorXd>& wait_request();
  /// Label of the last request.
  const std::string& label() const { return label_; }
  /// Values of the points of the last request (residuals may be empty when not needed).
  void deliver(std::vector<double> fitness, std::vector<std::vector<double>> residuals = {});

 private:
  enum class Phase { kIdle, kRunning, kRequest, kValues, kFinished };
  void worker();

  Body body_;
  std::thread thread_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  Phase phase_ = Phase::kIdle;
  bool abort_ = false;
  std::exception_ptr error_;
  std::vector<Eigen::VectorXd> points_;
  std::string label_;
  std::vector<double> fitness_;
  std::vector<std::vector<double>> residuals_;
};

}  // namespace insid::opt::detail
