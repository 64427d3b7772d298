// DVPIO: PIO with dimension-vector adaptive mutation (paper Sec. 2.2 and Fig. 2 steps 1-6).
//
// Flow. Iteration 1 evaluates a uniform initial population (velocities zero). Until the swarm is
// judged premature, every pigeon moves by the map-and-compass operator, Eq. 8-9 (shared with
// PIO: map_compass_move in pio.cc, with its choices: per-dimension rand by default, Nc = update
// count from 1, X_gbest = best-so-far, clamp + zero velocity at the box). DVPIO has no landmark
// phase: the paper's flow chart loops on Eq. 8-9 and then on step 5.
//
// Choices the paper leaves open (also in optimizers/README.md):
//  - Premature test (Eq. 10): after every batch that was not already premature (the initial
//    one included), Dist = mean_i ||X_gbest - X_i|| over all pigeons in the problem's
//    coordinates, X_gbest including the batch just evaluated. Dist < dist_threshold switches
//    the run to premature mode for good (step 6 loops to step 5).
//  - Premature iteration (step 5, Eq. 11-12): pigeons are ranked by the fitness of their
//    current positions, worst first (ties: lower index first). For each probed dimension j, in
//    order, the next worst pigeon goes to X_gbest + d_jp e_j and the one after it to
//    X_gbest - d_jn e_j (clamped to the box), with zero velocity. The other pigeons move by
//    Eq. 8-9 with their velocities and the running Nc.
//  - Population smaller than 2n: min(n, floor(N / 2)) dimensions are probed per iteration,
//    taken cyclically (0..k-1, then k..2k-1 mod n, ...); with N >= 2n every dimension is probed
//    every iteration and the cycle is trivial. Each dimension's T history is its own: Eq. 14
//    uses that dimension's last two probes.
//  - Eq. 13: T_j = -1 when f(negative probe) <= f(positive probe), else +1.
//  - Eq. 14 (docs/design.md sec. 2 reading), applied after the probe of dimension j whenever the
//    dimension has a previous T: with older = T(i-2), newer = T(i-1) and the current d (the
//    previous generation's values) on the right-hand side,
//      older = -1, newer = -1:  d_p = 0.5 d_n,  d_n = 2 d_n
//      older = +1, newer = +1:  d_p = 2 d_p,    d_n = 0.5 d_p
//      older = -1, newer = +1:  d_p = d_n = 0.5 d_p
//      older = +1, newer = -1:  d_p = d_n = 0.5 d_n
//    then clamp to [d_min, d_max]. The first probe of a dimension (only one T exists) leaves d
//    unchanged, so the first two premature iterations both use d_initial.
//  - Variant `shrink_without_gain` = 1 (not the paper's; default 0): when neither probe of
//    dimension j beats the X_gbest they were placed around, both d of j are halved (clamped at
//    d_min) and j's T history restarts, instead of Eq. 14. It removes the lock of the Eq. 14
//    reading (README.md), at the price of shrinking a dimension whose optimum lies just beyond
//    a probe that was too long.
//  - History: each record carries premature, the d used by the batch's probes (the current d
//    when not premature) and the batch's T flags (0 for dimensions not probed).
#include "optimizers/dvpio.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "optimizers/pio.h"

namespace insid::opt {

std::span<const ParameterField<DvpioParams>> DvpioParams::fields() {
  static const ParameterField<DvpioParams> kFields[] = {
      {"population", &DvpioParams::population, "number of pigeons"},
      {"R", &DvpioParams::R, "map-and-compass factor (Eq. 8)"},
      {"C", &DvpioParams::C, "weight of the pull towards the global best (Eq. 8)"},
      {"per_dimension_rand", &DvpioParams::per_dimension_rand,
       "1: rand drawn per dimension, 0: one rand per pigeon"},
      {"dist_threshold", &DvpioParams::dist_threshold,
       "premature when Dist (Eq. 10) is below this (problem units)", ParameterUnit::kBoxDistance},
      {"d_initial", &DvpioParams::d_initial, "initial dimension-vector size d (problem units)",
       ParameterUnit::kBoxDistance},
      {"d_min", &DvpioParams::d_min, "lower clamp of d (problem units)",
       ParameterUnit::kBoxDistance},
      {"d_max", &DvpioParams::d_max, "upper clamp of d (problem units)",
       ParameterUnit::kBoxDistance},
      {"shrink_without_gain", &DvpioParams::shrink_without_gain,
       "1: halve a dimension's d when neither probe beats X_gbest (insid variant, not Eq. 14)"},
  };
  return kFields;
}

std::string DvpioParams::validate() const {
  for (std::string error :
       {check_at_least(kAlgorithm, "population", population, 2),
        check_range(kAlgorithm, "R", R, 0.0, 1.0), check_range(kAlgorithm, "C", C, 0.0, 4.0),
        check_range(kAlgorithm, "per_dimension_rand", per_dimension_rand, 0.0, 1.0),
        check_range(kAlgorithm, "shrink_without_gain", shrink_without_gain, 0.0, 1.0),
        check_at_least(kAlgorithm, "dist_threshold", dist_threshold, 0.0),
        check_positive(kAlgorithm, "d_min", d_min), check_positive(kAlgorithm, "d_max", d_max)}) {
    if (!error.empty()) return error;
  }
  if (d_min > d_max) {
    return std::string(kAlgorithm) + ": d_min must be <= d_max, got d_min " + format_number(d_min) +
           " > d_max " + format_number(d_max);
  }
  return check_range(kAlgorithm, "d_initial", d_initial, d_min, d_max);
}

DvpioOptimizer::DvpioOptimizer(const Bounds& bounds, const RunConfig& config,
                               const DvpioParams& params)
    : Optimizer("DVPIO", bounds, config), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
  check_initial_positions(params_.population);
  const int n = this->bounds().dimension();
  d_positive_ = Eigen::VectorXd::Constant(n, params_.d_initial);
  d_negative_ = Eigen::VectorXd::Constant(n, params_.d_initial);
  last_flag_.assign(n, 0);
}

int DvpioOptimizer::dimensions_per_iteration() const {
  return std::min(bounds().dimension(), params_.population / 2);
}

std::string DvpioOptimizer::phase() const {
  if (iteration() == 0) return "initial";
  return batch_premature_ ? "dimension_vectors" : "map_compass";
}

void DvpioOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  const int n = bounds().dimension();
  batch_flags_.assign(n, 0);
  batch_d_positive_ = d_positive_;
  batch_d_negative_ = d_negative_;
  batch_premature_ = premature_;
  if (iteration() == 0) {
    x_ = initial_population(params_.population);
    v_.assign(x_.size(), Eigen::VectorXd::Zero(n));
  } else if (!premature_) {
    const int nc = iteration();  // update count: 1 for the first update
    for (std::size_t i = 0; i < x_.size(); ++i) {
      map_compass_move(bounds(), params_.R, params_.C, nc, params_.per_dimension_rand != 0,
                       best_x(), x_[i], v_[i], rng());  // Eq. 8-9
    }
  } else {
    propose_premature();
  }
  batch = x_;
}

void DvpioOptimizer::propose_premature() {
  const int n = bounds().dimension();
  const int count = static_cast<int>(x_.size());
  probe_positive_.assign(n, -1);
  probe_negative_.assign(n, -1);
  batch_gbest_f_ = best_f();

  // Step 5: natural selection, worst (largest fitness) first.
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return f_[a] > f_[b]; });

  std::vector<bool> is_probe(count, false);
  const int dims = dimensions_per_iteration();
  for (int q = 0; q < dims; ++q) {
    const int j = (probe_cursor_ + q) % n;
    const int plus = order[2 * q];
    const int minus = order[2 * q + 1];
    // Eq. 11-12: X = X_gbest + V_k, V_k = +d_jp e_j or -d_jn e_j.
    x_[plus] = best_x();
    x_[plus][j] += d_positive_[j];
    x_[minus] = best_x();
    x_[minus][j] -= d_negative_[j];
    x_[plus] = clamp(x_[plus]);
    x_[minus] = clamp(x_[minus]);
    v_[plus].setZero();
    v_[minus].setZero();
    probe_positive_[j] = plus;
    probe_negative_[j] = minus;
    is_probe[plus] = is_probe[minus] = true;
  }
  probe_cursor_ = (probe_cursor_ + dims) % n;

  const int nc = iteration();
  for (int i = 0; i < count; ++i) {  // the others: Eq. 8-9
    if (is_probe[i]) continue;
    map_compass_move(bounds(), params_.R, params_.C, nc, params_.per_dimension_rand != 0, best_x(),
                     x_[i], v_[i], rng());
  }
}

void DvpioOptimizer::adapt_d(int dim, int older, int newer) {
  // Eq. 14 (docs/design.md sec. 2 reading); right-hand sides use the previous generation's d.
  const double dp = d_positive_[dim];
  const double dn = d_negative_[dim];
  double new_dp = dp;
  double new_dn = dn;
  if (older == -1 && newer == -1) {  // keep going negative, bigger
    new_dp = 0.5 * dn;
    new_dn = 2.0 * dn;
  } else if (older == +1 && newer == +1) {  // keep going positive, bigger
    new_dp = 2.0 * dp;
    new_dn = 0.5 * dp;
  } else if (older == -1 && newer == +1) {  // direction flipped: near the optimum, shrink
    new_dp = new_dn = 0.5 * dp;
  } else {  // older == +1, newer == -1
    new_dp = new_dn = 0.5 * dn;
  }
  d_positive_[dim] = std::clamp(new_dp, params_.d_min, params_.d_max);
  d_negative_[dim] = std::clamp(new_dn, params_.d_min, params_.d_max);
}

void DvpioOptimizer::accept(std::span<const Eigen::VectorXd> batch,
                            std::span<const double> fitness) {
  f_.assign(fitness.begin(), fitness.end());
  const int n = bounds().dimension();
  if (batch_premature_) {
    for (int j = 0; j < n; ++j) {
      if (probe_positive_[j] < 0) continue;
      const double f_positive = fitness[probe_positive_[j]];
      const double f_negative = fitness[probe_negative_[j]];
      const int flag = f_negative <= f_positive ? -1 : +1;  // Eq. 13
      batch_flags_[j] = flag;
      if (params_.shrink_without_gain != 0 && f_positive >= batch_gbest_f_ &&
          f_negative >= batch_gbest_f_) {
        // Variant: no gain on either side, so X_gbest is within d of a local minimum along j
        // (as compass search reasons): halve both d, restart j's T history.
        d_positive_[j] = std::max(0.5 * d_positive_[j], params_.d_min);
        d_negative_[j] = std::max(0.5 * d_negative_[j], params_.d_min);
        last_flag_[j] = 0;
        continue;
      }
      if (last_flag_[j] != 0) adapt_d(j, last_flag_[j], flag);
      last_flag_[j] = flag;
    }
    return;
  }
  // Eq. 10: premature judgement on the positions just evaluated.
  double distance_sum = 0.0;
  for (const Eigen::VectorXd& x : batch) distance_sum += euclidean_distance(best_x(), x);
  const double dist = distance_sum / static_cast<double>(batch.size());
  if (dist < params_.dist_threshold) premature_ = true;
}

void DvpioOptimizer::annotate(IterationRecord& record) const {
  record.premature = batch_premature_;
  record.d_positive = batch_d_positive_;
  record.d_negative = batch_d_negative_;
  record.direction_flags = batch_flags_;
}

}  // namespace insid::opt
