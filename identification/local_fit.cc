#include "identification/local_fit.h"

#include <cmath>
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

}  // namespace

void residuals_at(const InsIdentificationProblem& problem, const Eigen::VectorXd& x,
                  std::vector<double>& r) {
  // Through the problem's residual path: the batched kernel when it covers the data (equal to
  // NavigationProblem::residuals within ~1e-12 relative, issue 6), else the scalar reference.
  double f = 0.0;
  problem.evaluate_residual_batch(std::span<const Eigen::VectorXd>(&x, 1),
                                  std::span<std::vector<double>>(&r, 1), std::span<double>(&f, 1));
}

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

LocalFitResult local_fit(const InsIdentificationProblem& problem, const Eigen::VectorXd& x0,
                         const LocalFitOptions& options) {
  if (const std::string why = options.validate(); !why.empty()) throw std::invalid_argument(why);
  const ParameterMapping& mapping = problem.mapping();
  const int n = mapping.dimension();
  LocalFitResult out;
  Eigen::VectorXd s = mapping.to_sigma(x0);  // work in sigma units
  const Eigen::VectorXd s_lo = mapping.to_sigma(Eigen::VectorXd::Constant(n, -1.0));
  const Eigen::VectorXd s_hi = mapping.to_sigma(Eigen::VectorXd::Constant(n, 1.0));
  auto clamp = [&](Eigen::VectorXd v) {
    if (options.clamp_to_box) v = v.cwiseMax(s_lo).cwiseMin(s_hi);
    return v;
  };
  // The objective at residuals r; with Eq. 15, `terms` gets its terms for the IRLS weights.
  auto objective = [&](const std::vector<double>& r, std::vector<double>& terms) {
    return options.eq15 ? eq15_terms(r, terms) : sum_sq(r);
  };

  std::vector<double> r, terms, terms_step;
  residuals_at(problem, mapping.from_sigma(s), r);
  ++out.evaluations;
  double f = objective(r, terms);
  double lambda = 1e-3;
  const std::size_t m = r.size();
  // The last Jacobian's residuals (its columns stay in r_columns): the result's J is built from
  // them once, at the end, rather than stored at every iteration (1.7 M rows for paper-fig9).
  std::vector<double> r_jacobian;
  Eigen::VectorXd h_jacobian;
  std::vector<double> r_step;
  std::vector<Eigen::VectorXd> x_columns(static_cast<std::size_t>(n));
  std::vector<std::vector<double>> r_columns(static_cast<std::size_t>(n));
  // Forward difference of row i, column j: (r_col - r_base) / h, in sigma units.
  const auto jacobian_entry = [&](int j, std::size_t i, const std::vector<double>& r_base,
                                  const Eigen::VectorXd& h) {
    return (r_columns[static_cast<std::size_t>(j)][i] - r_base[i]) / h[j];
  };
  std::vector<double> f_columns(static_cast<std::size_t>(n));
  for (int it = 0; it < options.max_iterations; ++it) {
    out.iterations = it + 1;
    // Forward-difference Jacobian in sigma units (one full INS run per column); the n columns
    // are scored as one batch, so the batched kernel runs them side by side.
    Eigen::VectorXd h = Eigen::VectorXd::Constant(n, options.step_sigma);
    for (int j = 0; j < n; ++j) {
      if (options.clamp_to_box && s[j] + h[j] > s_hi[j]) h[j] = -h[j];
      Eigen::VectorXd s_step = s;
      s_step[j] += h[j];
      x_columns[static_cast<std::size_t>(j)] = mapping.from_sigma(s_step);
    }
    problem.evaluate_residual_batch(x_columns, r_columns, f_columns);
    out.evaluations += n;
    r_jacobian = r;
    h_jacobian = h;
    // IRLS weights per epoch (both rows of an epoch share it); 1 without Eq. 15.
    const std::vector<double> w_epoch = options.eq15 ? eq15_weights(terms) : std::vector<double>{};
    // J^T W J and J^T W r in one pass over the rows, with the Jacobian row J_i = (r_col - r) / h
    // and the products of Eigen's JtWJ += w_i J_i^T J_i, JtWr += w_i J_i^T r_i in its order.
    Eigen::MatrixXd JtWJ = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd JtWr = Eigen::VectorXd::Zero(n);
    Eigen::VectorXd J_row(n), w_row(n);
    for (std::size_t i = 0; i < m; ++i) {
      const double w_i = i / 2 < w_epoch.size() ? w_epoch[i / 2] : 1.0;
      for (int a = 0; a < n; ++a) J_row[a] = jacobian_entry(a, i, r, h);
      for (int a = 0; a < n; ++a) w_row[a] = w_i * J_row[a];
      for (int b = 0; b < n; ++b)
        for (int a = 0; a < n; ++a) JtWJ(a, b) += J_row[b] * w_row[a];
      for (int a = 0; a < n; ++a) JtWr[a] += w_row[a] * r[i];
    }
    bool improved = false;
    Eigen::VectorXd step;
    for (int tries = 0; tries < 12 && !improved; ++tries) {
      Eigen::MatrixXd A = JtWJ;
      A.diagonal() += lambda * JtWJ.diagonal().cwiseMax(1e-30);
      step = -A.ldlt().solve(JtWr);
      const Eigen::VectorXd s_new = clamp(s + step);
      residuals_at(problem, mapping.from_sigma(s_new), r_step);
      ++out.evaluations;
      const double f_new = objective(r_step, terms_step);
      if (std::isfinite(f_new) && f_new <= f) {
        step = s_new - s;
        s = s_new;
        r.swap(r_step);
        terms.swap(terms_step);
        f = f_new;
        lambda = std::max(lambda * 0.3, 1e-9);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved || step.norm() < options.tolerance_sigma) break;
  }
  out.value_sigma = s;
  out.x = mapping.from_sigma(s);
  out.fitness = eq15(r);
  out.sum_squares = sum_sq(r);
  out.residuals = r;
  if (!r_jacobian.empty()) {
    Eigen::MatrixXd& J = out.jacobian_sigma;
    J.resize(static_cast<Eigen::Index>(m), n);
    for (int j = 0; j < n; ++j)
      for (std::size_t i = 0; i < m; ++i)
        J(static_cast<Eigen::Index>(i), j) = jacobian_entry(j, i, r_jacobian, h_jacobian);
  }
  return out;
}

}  // namespace insid
