#include "identification/local_fit.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <span>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

namespace insid {
namespace {

double eq15(const std::vector<double>& r) {
  double sum = 0.0;
  for (std::size_t e = 0; e + 1 < r.size(); e += 2) sum += std::hypot(r[e], r[e + 1]);
  return sum;
}

// The Eq. 15 terms |r_t| of a residual vector (dvE_t, dvN_t, ...), and their sum in eq15's
// order (the same bits as eq15(r)): the IRLS weights reuse the terms of the accepted point.
double eq15_terms(const std::vector<double>& r, std::vector<double>& terms) {
  terms.resize(r.size() / 2);
  double sum = 0.0;
  for (std::size_t e = 0; e < terms.size(); ++e)
    sum += terms[e] = std::hypot(r[2 * e], r[2 * e + 1]);
  return sum;
}

double sum_sq(const std::vector<double>& r) {
  double sum = 0.0;
  for (double v : r) sum += v * v;
  return sum;
}

// IRLS weights for Eq. 15, from its terms |r_t| (eq15_terms): minimising sum_t |r_t| is a fixed
// point of weighted least squares with w_t = 1 / |r_t| (floored to keep it finite at exact
// matches).
std::vector<double> eq15_weights(const std::vector<double>& terms) {
  std::vector<double> w(terms.size());
  double mean = 0.0;
  for (double t : terms) mean += t;
  mean /= static_cast<double>(std::max<std::size_t>(w.size(), 1));
  const double floor = std::max(1e-6 * mean, 1e-12);
  for (std::size_t e = 0; e < w.size(); ++e) w[e] = 1.0 / std::max(terms[e], floor);
  return w;
}

// Fit of one start, as a state machine that the lock-step driver (local_fits) advances: it asks
// for the candidates it waits for (request), and takes their residuals (advance). The
// arithmetic and its order are those of the sequential Levenberg-Marquardt loop:
//   r = residuals(s); for each iteration: Jacobian about s (n columns); up to 12 trials with
//   growing damping until one does not raise the objective; stop when none does, when the step
//   is below tolerance_sigma or after max_iterations.
class FitRun {
 public:
  FitRun(const InsIdentificationProblem& problem, const Eigen::VectorXd& x0,
         const LocalFitOptions& options)
      : mapping_(problem.mapping()),
        options_(options),
        n_(mapping_.dimension()),
        s_(mapping_.to_sigma(x0)),
        s_lo_(mapping_.to_sigma(Eigen::VectorXd::Constant(n_, -1.0))),
        s_hi_(mapping_.to_sigma(Eigen::VectorXd::Constant(n_, 1.0))),
        x_columns_(static_cast<std::size_t>(n_)),
        r_columns_(static_cast<std::size_t>(n_)) {
    x_trial_ = mapping_.from_sigma(s_);  // the start point, scored first
  }

  bool done() const { return state_ == State::kDone; }

  /// Appends the candidates this start waits for, and where their residuals go.
  void request(std::vector<Eigen::VectorXd>& xs, std::vector<std::vector<double>*>& outs) {
    if (state_ == State::kJacobian) {
      for (int j = 0; j < n_; ++j) {
        xs.push_back(x_columns_[static_cast<std::size_t>(j)]);
        outs.push_back(&r_columns_[static_cast<std::size_t>(j)]);
      }
    } else if (state_ == State::kStart || state_ == State::kTrial) {
      xs.push_back(x_trial_);
      outs.push_back(&r_step_);
    }
  }

  /// Takes the residuals of the candidates requested last (already in place) and moves on.
  void advance() {
    switch (state_) {
      case State::kStart:
        r_.swap(r_step_);
        ++out_.evaluations;
        f_ = objective(r_, terms_);
        next_iteration();
        break;
      case State::kJacobian:
        out_.evaluations += n_;
        normal_equations();
        propose_trial();
        break;
      case State::kTrial:
        judge_trial();
        break;
      case State::kDone:
        break;
    }
  }

  LocalFitResult result() {
    out_.value_sigma = s_;
    out_.x = mapping_.from_sigma(s_);
    out_.fitness = eq15(r_);
    out_.sum_squares = sum_sq(r_);
    if (options_.keep_jacobian && iteration_ > 0) {
      // The last Jacobian's base: r itself when no step was accepted after it.
      const std::vector<double>& r_base = base_is_r_ ? r_ : r_jacobian_;
      const std::size_t m = r_base.size();
      Eigen::MatrixXd& J = out_.jacobian_sigma;
      J.resize(static_cast<Eigen::Index>(m), n_);
      for (int j = 0; j < n_; ++j)
        for (std::size_t i = 0; i < m; ++i)
          J(static_cast<Eigen::Index>(i), j) = jacobian_entry(j, i, r_base, h_);
    }
    out_.residuals = std::move(r_);
    return std::move(out_);
  }

 private:
  enum class State { kStart, kJacobian, kTrial, kDone };

  // The objective at residuals r; with Eq. 15, `terms` gets its terms for the IRLS weights.
  double objective(const std::vector<double>& r, std::vector<double>& terms) const {
    return options_.eq15 ? eq15_terms(r, terms) : sum_sq(r);
  }
  Eigen::VectorXd clamp(Eigen::VectorXd v) const {
    if (options_.clamp_to_box) v = v.cwiseMax(s_lo_).cwiseMin(s_hi_);
    return v;
  }
  // Forward difference of row i, column j: (r_col - r_base) / h, in sigma units.
  double jacobian_entry(int j, std::size_t i, const std::vector<double>& r_base,
                        const Eigen::VectorXd& h) const {
    return (r_columns_[static_cast<std::size_t>(j)][i] - r_base[i]) / h[j];
  }

  // Forward-difference Jacobian in sigma units (one full INS run per column) about s.
  void next_iteration() {
    if (iteration_ >= options_.max_iterations) {
      state_ = State::kDone;
      return;
    }
    out_.iterations = ++iteration_;
    h_ = Eigen::VectorXd::Constant(n_, options_.step_sigma);
    for (int j = 0; j < n_; ++j) {
      if (options_.clamp_to_box && s_[j] + h_[j] > s_hi_[j]) h_[j] = -h_[j];
      Eigen::VectorXd s_step = s_;
      s_step[j] += h_[j];
      x_columns_[static_cast<std::size_t>(j)] = mapping_.from_sigma(s_step);
    }
    state_ = State::kJacobian;
  }

  // J^T W J and J^T W r in one pass over the rows, with the Jacobian row J_i = (r_col - r) / h
  // and the products of Eigen's JtWJ += w_i J_i^T J_i, JtWr += w_i J_i^T r_i in its order; IRLS
  // weights per epoch (both rows of an epoch share it), 1 without Eq. 15.
  void normal_equations() {
    base_is_r_ = true;
    const std::vector<double> w_epoch =
        options_.eq15 ? eq15_weights(terms_) : std::vector<double>{};
    JtWJ_ = Eigen::MatrixXd::Zero(n_, n_);
    JtWr_ = Eigen::VectorXd::Zero(n_);
    Eigen::VectorXd J_row(n_), w_row(n_);
    for (std::size_t i = 0; i < r_.size(); ++i) {
      const double w_i = i / 2 < w_epoch.size() ? w_epoch[i / 2] : 1.0;
      for (int a = 0; a < n_; ++a) J_row[a] = jacobian_entry(a, i, r_, h_);
      for (int a = 0; a < n_; ++a) w_row[a] = w_i * J_row[a];
      for (int b = 0; b < n_; ++b)
        for (int a = 0; a < n_; ++a) JtWJ_(a, b) += J_row[b] * w_row[a];
      for (int a = 0; a < n_; ++a) JtWr_[a] += w_row[a] * r_[i];
    }
    tries_ = 0;
  }

  void propose_trial() {
    Eigen::MatrixXd A = JtWJ_;
    A.diagonal() += lambda_ * JtWJ_.diagonal().cwiseMax(1e-30);
    const Eigen::VectorXd step = -A.ldlt().solve(JtWr_);
    s_new_ = clamp(s_ + step);
    x_trial_ = mapping_.from_sigma(s_new_);
    state_ = State::kTrial;
  }

  void judge_trial() {
    ++out_.evaluations;
    ++tries_;
    const double f_new = objective(r_step_, terms_step_);
    if (std::isfinite(f_new) && f_new <= f_) {
      const Eigen::VectorXd step = s_new_ - s_;
      s_ = s_new_;
      // The Jacobian's base moves aside (the result's Jacobian may need it); r takes the trial.
      r_jacobian_.swap(r_);
      base_is_r_ = false;
      r_.swap(r_step_);
      terms_.swap(terms_step_);
      f_ = f_new;
      lambda_ = std::max(lambda_ * 0.3, 1e-9);
      if (step.norm() < options_.tolerance_sigma)
        state_ = State::kDone;
      else
        next_iteration();
      return;
    }
    lambda_ *= 10.0;
    if (tries_ < 12)
      propose_trial();
    else
      state_ = State::kDone;
  }

  const ParameterMapping& mapping_;
  const LocalFitOptions& options_;
  const int n_;
  State state_ = State::kStart;
  LocalFitResult out_;
  Eigen::VectorXd s_;  // the estimate, sigma units
  const Eigen::VectorXd s_lo_, s_hi_;
  std::vector<double> r_, terms_;  // residuals and Eq. 15 terms at s
  double f_ = 0.0;                 // objective at s
  double lambda_ = 1e-3;
  int iteration_ = 0, tries_ = 0;
  Eigen::VectorXd h_;  // the last Jacobian's steps
  std::vector<Eigen::VectorXd> x_columns_;
  std::vector<std::vector<double>> r_columns_;
  // The last Jacobian's base residuals, once a step moved s away from it (base_is_r_ false);
  // the result's J is built from them once, at the end, rather than stored at every iteration
  // (1.7 M rows for paper-fig9).
  std::vector<double> r_jacobian_;
  bool base_is_r_ = true;
  Eigen::MatrixXd JtWJ_;
  Eigen::VectorXd JtWr_;
  Eigen::VectorXd s_new_, x_trial_;
  std::vector<double> r_step_, terms_step_;  // residuals and terms of the trial (or start) point
};

}  // namespace

std::string LocalFitOptions::validate() const {
  if (max_iterations < 0)
    return "local fit: max_iterations must be >= 0, got " + std::to_string(max_iterations);
  if (!(step_sigma > 0.0 && std::isfinite(step_sigma)))
    return "local fit: step_sigma must be a positive finite number (sigma units), got " +
           std::to_string(step_sigma);
  if (!(tolerance_sigma >= 0.0 && std::isfinite(tolerance_sigma)))
    return "local fit: tolerance_sigma must be a non-negative finite number (sigma units), got " +
           std::to_string(tolerance_sigma);
  return "";
}

std::vector<LocalFitResult> local_fits(const InsIdentificationProblem& problem,
                                       std::span<const Eigen::VectorXd> x0s,
                                       const LocalFitOptions& options, int threads) {
  if (const std::string why = options.validate(); !why.empty()) throw std::invalid_argument(why);
  if (threads < 1)
    throw std::invalid_argument("local fit: threads must be >= 1, got " + std::to_string(threads));
  std::vector<FitRun> runs;
  runs.reserve(x0s.size());
  for (const Eigen::VectorXd& x0 : x0s) runs.emplace_back(problem, x0, options);
  std::vector<Eigen::VectorXd> xs;
  std::vector<std::vector<double>*> outs;
  std::vector<std::vector<double>> batch;  // the residual slots of one round
  std::vector<double> f;
  std::vector<int> active;
  for (;;) {
    xs.clear();
    outs.clear();
    active.clear();
    for (std::size_t i = 0; i < runs.size(); ++i) {
      if (runs[i].done()) continue;
      active.push_back(static_cast<int>(i));
      runs[i].request(xs, outs);
    }
    if (active.empty()) break;
    // One batch for every start: the slots are the starts' own buffers, lent and given back.
    batch.resize(xs.size());
    f.resize(xs.size());
    for (std::size_t k = 0; k < xs.size(); ++k) batch[k].swap(*outs[k]);
    problem.evaluate_residual_batch(xs, batch, f);
    for (std::size_t k = 0; k < xs.size(); ++k) batch[k].swap(*outs[k]);
    // Each start's own linear algebra touches only its own state.
    const int n_active = static_cast<int>(active.size());
    std::vector<std::exception_ptr> errors(active.size());
#pragma omp parallel for schedule(dynamic, 1) \
    num_threads(std::min(threads, n_active)) if (threads > 1 && n_active > 1)
    for (int a = 0; a < n_active; ++a) {
      try {
        runs[static_cast<std::size_t>(active[a])].advance();
      } catch (...) {
        errors[static_cast<std::size_t>(a)] = std::current_exception();
      }
    }
    for (const std::exception_ptr& error : errors)
      if (error) std::rethrow_exception(error);
  }
  std::vector<LocalFitResult> results;
  results.reserve(runs.size());
  for (FitRun& run : runs) results.push_back(run.result());
  return results;
}

LocalFitResult local_fit(const InsIdentificationProblem& problem, const Eigen::VectorXd& x0,
                         const LocalFitOptions& options) {
  return std::move(local_fits(problem, std::span<const Eigen::VectorXd>(&x0, 1), options)[0]);
}

}  // namespace insid
