// Pigeon-inspired optimisation (Duan & Qiao 2014), paper Eq. 8-9.
//
// Choices the paper leaves open (also in optimizers/README.md):
//  - rand in Eq. 8: drawn per dimension by default (per_dimension_rand = 1), like PSO; with 0,
//    one draw per pigeon moves it along the line towards X_gbest.
//  - Nc: the update count, 1 for the first update (iteration 2, the initial population being
//    iteration 1). exp(-R Nc) multiplies V at every update, so V decays as exp(-R Nc(Nc+1)/2).
//  - X_gbest: the run's best-so-far point, including the batch just evaluated.
//  - Initial positions uniform in the box; initial velocities zero.
//  - Bounds: a coordinate leaving the box is clamped to the face and that velocity component
//    set to zero (landmark moves stay inside: they go towards a centre inside the box).
//  - Schedule: of P planned iterations (max_iterations, or ceil(max_evaluations / population)
//    when only an evaluation budget is set), the last round(landmark_fraction * P) use the
//    landmark operator, the rest map-and-compass. Paper preset: 40 iterations, fraction 0.25:
//    30 map-and-compass (the initial population included) then 10 landmark. With only an
//    evaluation budget the landmark phase runs until the budget is spent.
//  - Landmark operator (Duan & Qiao's Eq. 3-5): sort the pigeons by fitness, keep the better
//    half, ceil(N / 2) but at least landmark_min_population (default 2: with one pigeon the
//    centre is that pigeon and nothing moves); centre X_c = sum_r w_r X_r / sum_r w_r with rank
//    weights w_r = N_kept - r (r = 0 for the best). Rank weights replace the original
//    fitness-proportional weights, which are not invariant to shifting the fitness and, for
//    minimisation, undefined in sign. Then X_r <- X_r + rand (X_c - X_r), rand as above.
//    The population is halved at the first landmark iteration already (10 -> 5 -> 3 -> 2 ...).
//  - Draw order: initial positions; each update: pigeon 0 dimension 0, 1, ..., pigeon 1, ...
#include "optimizers/pio.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace insid::opt {

std::span<const ParameterField<PioParams>> PioParams::fields() {
  static const ParameterField<PioParams> kFields[] = {
      {"population", &PioParams::population, "number of pigeons"},
      {"R", &PioParams::R, "map-and-compass factor (Eq. 8)"},
      {"C", &PioParams::C, "weight of the pull towards the global best (Eq. 8)"},
      {"landmark_fraction", &PioParams::landmark_fraction,
       "share of the planned iterations given to the landmark operator"},
      {"landmark_min_population", &PioParams::landmark_min_population,
       "the landmark operator's halving stops at this many pigeons"},
      {"per_dimension_rand", &PioParams::per_dimension_rand,
       "1: rand drawn per dimension, 0: one rand per pigeon"},
  };
  return kFields;
}

std::string PioParams::validate() const {
  for (std::string error :
       {check_at_least(kAlgorithm, "population", population, 1),
        check_range(kAlgorithm, "R", R, 0.0, 1.0), check_range(kAlgorithm, "C", C, 0.0, 4.0),
        check_range(kAlgorithm, "landmark_fraction", landmark_fraction, 0.0, 1.0),
        check_range(kAlgorithm, "landmark_min_population", landmark_min_population, 1.0,
                    population),
        check_range(kAlgorithm, "per_dimension_rand", per_dimension_rand, 0.0, 1.0)}) {
    if (!error.empty()) return error;
  }
  return {};
}

void map_compass_move(const Bounds& bounds, double R, double C, int nc, bool per_dimension_rand,
                      const Eigen::VectorXd& x_gbest, Eigen::VectorXd& x, Eigen::VectorXd& v,
                      Rng& rng) {
  const double decay = std::exp(-R * nc);
  double r = per_dimension_rand ? 0.0 : rng.uniform();
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    if (per_dimension_rand) r = rng.uniform();
    v[j] = v[j] * decay + C * r * (x_gbest[j] - x[j]);  // Eq. 8
    x[j] += v[j];                                       // Eq. 9
    if (x[j] < bounds.lower[j] || x[j] > bounds.upper[j]) {
      x[j] = std::clamp(x[j], bounds.lower[j], bounds.upper[j]);
      v[j] = 0.0;
    }
  }
}

PioOptimizer::PioOptimizer(const Bounds& bounds, const RunConfig& config, const PioParams& params)
    : Optimizer("PIO", bounds, config), params_(params) {
  if (std::string error = params_.validate(); !error.empty()) throw std::invalid_argument(error);
  check_initial_positions(params_.population);
  const int planned = planned_iterations(params_.population);
  const int landmark = static_cast<int>(std::lround(params_.landmark_fraction * planned));
  map_compass_iterations_ = std::max(1, planned - landmark);
}

void PioOptimizer::propose(std::vector<Eigen::VectorXd>& batch) {
  const int next = iteration() + 1;
  if (next == 1) {
    phase_ = "initial";
    x_ = initial_population(params_.population);
    v_.assign(x_.size(), Eigen::VectorXd::Zero(bounds().dimension()));
  } else if (next <= map_compass_iterations_) {
    phase_ = "map_compass";
    const int nc = next - 1;
    for (std::size_t i = 0; i < x_.size(); ++i) {
      map_compass_move(bounds(), params_.R, params_.C, nc, params_.per_dimension_rand != 0,
                       best_x(), x_[i], v_[i], rng());
    }
  } else {
    phase_ = "landmark";
    landmark_step();
  }
  batch = x_;
}

void PioOptimizer::landmark_step() {
  const int count = static_cast<int>(x_.size());
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return f_[a] < f_[b]; });

  int kept = (count + 1) / 2;
  if (kept < params_.landmark_min_population)
    kept = std::min(params_.landmark_min_population, count);

  std::vector<Eigen::VectorXd> x(kept), v(kept);
  Eigen::VectorXd centre = Eigen::VectorXd::Zero(bounds().dimension());
  double weight_sum = 0.0;
  for (int r = 0; r < kept; ++r) {
    x[r] = x_[order[r]];
    v[r] = v_[order[r]];
    const double weight = kept - r;  // rank weight, best = kept
    centre += weight * x[r];
    weight_sum += weight;
  }
  centre /= weight_sum;

  const bool per_dimension = params_.per_dimension_rand != 0;
  for (Eigen::VectorXd& xr : x) {
    double rand = per_dimension ? 0.0 : rng().uniform();
    for (Eigen::Index j = 0; j < xr.size(); ++j) {
      if (per_dimension) rand = rng().uniform();
      xr[j] += rand * (centre[j] - xr[j]);
    }
    xr = clamp(xr);  // only guards rounding: the move is a convex combination
  }
  x_ = std::move(x);
  v_ = std::move(v);
}

void PioOptimizer::accept(std::span<const Eigen::VectorXd>, std::span<const double> fitness) {
  f_.assign(fitness.begin(), fitness.end());
}

}  // namespace insid::opt
