#include "optimizers/solver_bridge.h"

#include <stdexcept>

namespace insid::opt::detail {

SolverBridge::~SolverBridge() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    abort_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool SolverBridge::aborting() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return abort_;
}

void SolverBridge::worker() {
  std::exception_ptr error;
  try {
    body_(*this);
  } catch (const Aborted&) {
    // stopped on request
  } catch (...) {
    error = std::current_exception();
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = error;
    phase_ = Phase::kFinished;
  }
  cv_.notify_all();
}

bool SolverBridge::request(std::vector<Eigen::VectorXd> points, std::vector<double>& fitness,
                           std::vector<std::vector<double>>* residuals, std::string label) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (abort_) return false;
  points_ = std::move(points);
  label_ = std::move(label);
  phase_ = Phase::kRequest;
  cv_.notify_all();
  cv_.wait(lock, [this] { return abort_ || phase_ == Phase::kValues; });
  if (abort_) return false;
  fitness = std::move(fitness_);
  if (residuals != nullptr) *residuals = std::move(residuals_);
  residuals_.clear();
  phase_ = Phase::kRunning;
  return true;
}

const std::vector<Eigen::VectorXd>& SolverBridge::wait_request() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (phase_ == Phase::kIdle) {
    phase_ = Phase::kRunning;
    thread_ = std::thread([this] { worker(); });
  }
  cv_.wait(lock, [this] { return phase_ == Phase::kRequest || phase_ == Phase::kFinished; });
  if (phase_ == Phase::kFinished) {
    if (error_) std::rethrow_exception(error_);
    throw std::logic_error("solver bridge: the solver ended without being stopped");
  }
  return points_;
}

void SolverBridge::deliver(std::vector<double> fitness,
                           std::vector<std::vector<double>> residuals) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (phase_ != Phase::kRequest)
      throw std::logic_error("solver bridge: deliver() without a request");
    if (fitness.size() != points_.size())
      throw std::logic_error("solver bridge: wrong number of values");
    fitness_ = std::move(fitness);
    residuals_ = std::move(residuals);
    phase_ = Phase::kValues;
  }
  cv_.notify_all();
}

}  // namespace insid::opt::detail
