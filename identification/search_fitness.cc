#include "identification/search_fitness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "base/number_text.h"
#include "kernel/batch_kernel.h"
#include "kernel/cpu_path.h"

namespace insid {
namespace {

// Candidates scored together over one pass of the data (their node values stay in L1).
constexpr std::size_t kChunk = batch_kernel::kSumNormsLanes;

// The model's features of dx = x - c, in the order of the coefficient rows: dx_i (d), dx_i^2 / 2
// (d), dx_i dx_j for i < j (d(d - 1)/2). `order` 1 leaves the second-order ones 0.
void features(const Eigen::VectorXd& dx, int order, double* phi) {
  const Eigen::Index d = dx.size();
  Eigen::Index p = 0;
  for (Eigen::Index i = 0; i < d; ++i) phi[p++] = dx[i];
  for (Eigen::Index i = 0; i < d; ++i) phi[p++] = order >= 2 ? 0.5 * dx[i] * dx[i] : 0.0;
  for (Eigen::Index i = 0; i < d; ++i)
    for (Eigen::Index j = i + 1; j < d; ++j) phi[p++] = order >= 2 ? dx[i] * dx[j] : 0.0;
}

}  // namespace

std::string FastFitnessOptions::validate() const {
  if (!(step > 0.0 && step <= 0.5))
    return "fast fitness: step must be in (0, 0.5], got " + number_text(step);
  if (!(node_spacing_s > 0.0 && std::isfinite(node_spacing_s)))
    return "fast fitness: node_spacing_s must be finite and > 0, got " +
           number_text(node_spacing_s);
  if (!(tolerance > 0.0 && std::isfinite(tolerance)))
    return "fast fitness: tolerance must be finite and > 0, got " + number_text(tolerance);
  if (check_points < 1)
    return "fast fitness: check_points must be >= 1, got " + std::to_string(check_points);
  if (order != 1 && order != 2)
    return "fast fitness: order must be 1 or 2, got " + std::to_string(order);
  return "";
}

FastFitness::FastFitness(const InsIdentificationProblem& exact, FastFitnessOptions options)
    : options_(std::move(options)) {
  if (const std::string why = options_.validate(); !why.empty()) throw std::invalid_argument(why);
  const auto t0 = std::chrono::steady_clock::now();
  build(exact);

  // The check: seeded uniform points of the box, the model against the exact kernel.
  std::mt19937_64 rng(options_.check_seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Eigen::VectorXd> xs;
  const opt::Bounds& box = exact.bounds();
  for (int n = 0; n < options_.check_points; ++n) {
    Eigen::VectorXd x(d_);
    for (int i = 0; i < d_; ++i) {
      const double u = 0.5 * (uniform(rng) + 1.0);
      x[i] = box.lower[i] + u * (box.upper[i] - box.lower[i]);
    }
    xs.push_back(x);
  }
  std::vector<double> f_exact(xs.size()), f_model(xs.size());
  exact.evaluate_batch(xs, f_exact);
  evaluate(xs, f_model, exact.evaluator().threads());
  for (std::size_t n = 0; n < xs.size(); ++n) {
    double relative = std::abs(f_model[n] - f_exact[n]) / f_exact[n];
    if (!std::isfinite(relative)) relative = std::numeric_limits<double>::infinity();  // NaN too
    check_max_relative_difference_ = std::max(check_max_relative_difference_, relative);
  }
  build_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void FastFitness::build(const InsIdentificationProblem& exact) {
  const NavigationProblem& nav = exact.navigation();
  d_ = exact.mapping().dimension();
  features_ = d_ + d_ * (d_ + 1) / 2;
  epochs_ = nav.num_epochs();
  const opt::Bounds& box = exact.bounds();
  centre_ = 0.5 * (box.lower + box.upper);
  const double h = options_.step;

  // The exact runs: c, c +- h e_i, c + h (e_i + e_j) for i < j.
  std::vector<Eigen::VectorXd> points{centre_};
  for (int i = 0; i < d_; ++i) {
    Eigen::VectorXd a = centre_, b = centre_;
    a[i] += h;
    b[i] -= h;
    points.push_back(a);
    points.push_back(b);
  }
  for (int i = 0; i < d_; ++i)
    for (int j = i + 1; j < d_; ++j) {
      Eigen::VectorXd a = centre_;
      a[i] += h;
      a[j] += h;
      points.push_back(a);
    }
  exact_runs_ = static_cast<int>(points.size());
  std::vector<std::vector<double>> R(points.size());
  std::vector<double> f(points.size());
  exact.evaluate_residual_batch(points, R, f);
  const auto plus = [&](int i) -> const std::vector<double>& { return R[1 + 2 * i]; };
  const auto minus = [&](int i) -> const std::vector<double>& { return R[2 + 2 * i]; };
  r0_ = R[0];

  // Fitness windows: a restart starts a new segment, whose first and last epochs are nodes.
  const Dataset& data = nav.dataset();
  std::vector<double> restart_t;
  for (const WindowRestart& r : nav.window_restarts())
    restart_t.push_back(data.imu[r.imu_index].t_s);
  std::vector<double> t(epochs_);
  for (std::size_t e = 0; e < epochs_; ++e) t[e] = data.gnss[nav.epoch_gnss_indices()[e]].t_s;
  std::vector<std::size_t> segment_start{0};
  {
    std::size_t j = 0;
    for (std::size_t e = 0; e < epochs_; ++e) {
      bool crossed = false;
      while (j < restart_t.size() && t[e] > restart_t[j]) {
        ++j;
        crossed = true;
      }
      if (crossed && e > 0 && segment_start.back() != e) segment_start.push_back(e);
    }
  }
  segment_start.push_back(epochs_);

  // The coefficients at a node epoch e: J and H rows for east, then north.
  const auto add_node = [&](std::size_t e) {
    node_epoch_.push_back(e);
    for (std::size_t c = 0; c < 2; ++c) {
      const std::size_t k = 2 * e + c;
      const double r0 = R[0][k];
      for (int i = 0; i < d_; ++i) coeff_.push_back((plus(i)[k] - minus(i)[k]) / (2.0 * h));
      for (int i = 0; i < d_; ++i)
        coeff_.push_back((plus(i)[k] + minus(i)[k] - 2.0 * r0) / (h * h));
      std::size_t m = 1 + 2 * static_cast<std::size_t>(d_);
      for (int i = 0; i < d_; ++i)
        for (int j = i + 1; j < d_; ++j, ++m)
          coeff_.push_back((R[m][k] - plus(i)[k] - plus(j)[k] + r0) / (h * h));
    }
    return node_epoch_.size() - 1;
  };
  w_.assign(epochs_, 0.0);
  for (std::size_t s = 0; s + 1 < segment_start.size(); ++s) {
    const std::size_t first = segment_start[s], end = segment_start[s + 1];
    if (first == end) continue;
    std::size_t a = first, node_a = add_node(first);
    if (end - first == 1) {
      blocks_.push_back({first, end, node_a, node_a});
      continue;
    }
    while (a + 1 < end) {
      std::size_t b = a + 1;
      while (b + 1 < end && t[b + 1] - t[a] <= options_.node_spacing_s) ++b;
      const std::size_t node_b = add_node(b);
      const bool last = b == end - 1;
      const std::size_t stop = last ? end : b;  // the segment's last node is its own epoch
      const double span = t[b] - t[a];
      for (std::size_t e = a; e < stop; ++e)
        w_[e] = span > 0.0 ? (t[e] - t[a]) / span
                           : static_cast<double>(e - a) / static_cast<double>(b - a);
      blocks_.push_back({a, stop, node_a, node_b});
      a = b;
      node_a = node_b;
    }
  }
}

void FastFitness::evaluate_chunk(std::span<const Eigen::VectorXd> xs, std::size_t k0, std::size_t n,
                                 std::span<double> f_out) const {
  const std::size_t P = static_cast<std::size_t>(features_);
  // phi[p][k]: the candidates' features, candidates innermost (unused lanes 0).
  std::vector<double> phi(P * kChunk, 0.0), feature(P);
  for (std::size_t k = 0; k < n; ++k) {
    features(xs[k0 + k] - centre_, options_.order, feature.data());
    for (std::size_t p = 0; p < P; ++p) phi[p * kChunk + k] = feature[p];
  }
  alignas(64) double acc[kChunk] = {};
  cpu_path().sum_norms(r0_.data(), w_.data(), coeff_.data(), P, phi.data(), blocks_.data(),
                       blocks_.size(), acc);
  for (std::size_t k = 0; k < n; ++k) f_out[k0 + k] = acc[k];
}

void FastFitness::evaluate(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
                           int threads) const {
  if (f_out.size() != xs.size())
    throw std::invalid_argument("fast fitness: " + std::to_string(xs.size()) + " candidates but " +
                                std::to_string(f_out.size()) + " output slots");
  for (std::size_t k = 0; k < xs.size(); ++k)
    if (xs[k].size() != d_)
      throw std::invalid_argument("fast fitness: candidate " + std::to_string(k) + " has " +
                                  std::to_string(xs[k].size()) + " coordinates, expected " +
                                  std::to_string(d_));
  const std::int64_t chunks = static_cast<std::int64_t>((xs.size() + kChunk - 1) / kChunk);
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::max(threads, 1)) if (chunks > 1)
  for (std::int64_t c = 0; c < chunks; ++c) {
    const std::size_t k0 = static_cast<std::size_t>(c) * kChunk;
    evaluate_chunk(xs, k0, std::min(kChunk, xs.size() - k0), f_out);
  }
}

std::vector<double> FastFitness::residuals(const Eigen::VectorXd& x) const {
  const std::size_t P = static_cast<std::size_t>(features_);
  std::vector<double> phi(P);
  features(x - centre_, options_.order, phi.data());
  const auto value = [&](std::size_t node, std::size_t comp) {
    double v = 0.0;
    for (std::size_t p = 0; p < P; ++p) v += coeff_[node * 2 * P + comp * P + p] * phi[p];
    return v;
  };
  std::vector<double> r(2 * epochs_);
  for (const batch_kernel::SumBlock& block : blocks_)
    for (std::size_t comp = 0; comp < 2; ++comp) {
      const double a = value(block.node_a, comp), b = value(block.node_b, comp);
      for (std::size_t e = block.first_epoch; e < block.end_epoch; ++e)
        r[2 * e + comp] = r0_[2 * e + comp] + (a + w_[e] * (b - a));
    }
  return r;
}

nlohmann::json FastFitness::to_json() const {
  return {{"model", options_.order == 2 ? "second-order residual model at the box centre"
                                        : "first-order residual model at the box centre"},
          {"step", options_.step},
          {"node_spacing_s", options_.node_spacing_s},
          {"nodes", nodes()},
          {"epochs", epochs_},
          {"exact_runs_to_build", exact_runs_},
          {"check_points", options_.check_points},
          {"check_seed", options_.check_seed},
          {"check_max_relative_difference", check_max_relative_difference_},
          {"tolerance", options_.tolerance},
          {"build_s", build_s_}};
}

SearchProblem::SearchProblem(const InsIdentificationProblem& exact, SearchFitnessKind kind,
                             FastFitnessOptions options)
    : opt::Problem(exact.bounds()), exact_(exact), requested_(kind) {
  if (kind == SearchFitnessKind::kExact) return;
  if (const std::string why = options.validate(); !why.empty()) throw std::invalid_argument(why);
  try {
    fast_ = std::make_unique<FastFitness>(exact, std::move(options));
  } catch (const std::exception& e) {  // an exact run of the build or check failed
    reason_ = std::string("the second-order model could not be built (") + e.what() +
              "): the search runs on the exact kernel";
    return;
  }
  if (!fast_->usable())
    reason_ = "the second-order model's check on " + std::to_string(fast_->options().check_points) +
              " box points differs from the exact kernel by up to " +
              number_text(fast_->check_max_relative_difference(), 3) +
              " relative, beyond the tolerance " + number_text(fast_->options().tolerance, 3) +
              ": the search runs on the exact kernel";
}

void SearchProblem::evaluate_batch(std::span<const Eigen::VectorXd> xs,
                                   std::span<double> f_out) const {
  if (uses_fast())
    fast_->evaluate(xs, f_out, exact_.evaluator().threads());
  else
    exact_.evaluate_batch(xs, f_out);
}

std::vector<double> SearchProblem::exact_fitness(std::span<const Eigen::VectorXd> xs) const {
  std::vector<double> f(xs.size());
  exact_.evaluate_batch(xs, f);
  return f;
}

nlohmann::json SearchProblem::to_json() const {
  nlohmann::json j = {
      {"requested", to_string(requested_)}, {"used", used()}, {"reported", "exact"}};
  if (fast_) j["fast"] = fast_->to_json();
  if (!reason_.empty()) j["reason"] = reason_;
  return j;
}

}  // namespace insid
