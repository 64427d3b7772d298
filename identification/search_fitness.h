// The search fitness (issue 47, docs/design.md sec. 12 "Two fitnesses, one contract"): what the
// optimizers are steered by, and the exact kernel that scores every number insid reports.
//
// The fast search fitness is a second-order model of the residual vector in the normalised
// parameters x, built once from exact runs at the box centre c:
//
//   r_t(x) = r_t(c) + J_t dx + 1/2 sum_i dx_i^2 H_t,ii + sum_{i<j} dx_i dx_j H_t,ij,  dx = x - c,
//
// r_t = (dvE_t, dvN_t) at GNSS epoch t (NavigationProblem::residuals), J_t by central
// differences, H_t,ii by central second differences, H_t,ij by forward ones, with the step
// FastFitnessOptions::step: 1 + 2d + d(d - 1)/2 exact runs, scored together by the batched kernel.
// r_t(c) is kept at every epoch (it carries the GNSS noise, which no smooth model follows);
// the x-dependent part is kept at nodes every `node_spacing_s` seconds of a fitness window and
// interpolated linearly in time between them (it follows the slow error dynamics: the Schuler
// period is 84 min; a restart of the windowed fitness is a node, never interpolated across).
// Eq. 15 of the model is then sum_t |r_t(x)|: per candidate and epoch one interpolation, a norm
// and a square root, instead of a strapdown step.
//
// What bounds it: the Taylor remainder (third order in dx) and the interpolation between nodes.
// Neither is bounded analytically here; both are measured. At build time the model is scored
// against the exact kernel on `check_points` seeded points of the box, and used only when the
// largest relative difference of Eq. 15 is within `tolerance` (else the search runs on the exact
// kernel, and says why). results/perf/fast-fitness/ measures 1000 box points and 100 points near
// the optimum per flight (issue 47's criterion 1). A model taken once does not hold over a MEMS
// box (a gyro bias near the box edge turns the attitude by degrees within a window, and the
// attitude is carried from window to window: far from linear): there the check refuses it.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "base/enum_table.h"
#include "identification/ins_problem.h"
#include "kernel/batch_kernel.h"
#include "optimizers/problem.h"

namespace insid {

/// Which fitness steers the search. The exact kernel scores every reported number either way.
enum class SearchFitnessKind {
  kFast,   ///< the second-order model below when its check passes, else the exact kernel
  kExact,  ///< the exact kernel (InsIdentificationProblem) for every candidate
};
inline constexpr EnumTable<SearchFitnessKind, 2> kSearchFitnessNames{
    "search fitness", {{{SearchFitnessKind::kFast, "fast"}, {SearchFitnessKind::kExact, "exact"}}}};
inline std::string_view to_string(SearchFitnessKind kind) { return kSearchFitnessNames.name(kind); }

struct FastFitnessOptions {
  double step = 0.02;  ///< finite-difference step, normalised box units (0, 0.5]
  /// Time between nodes of the x-dependent part (s), > 0: the next node is the last epoch
  /// within node_spacing_s of the one before, at least the next epoch.
  double node_spacing_s = 0.2;
  double tolerance = 1e-4;  ///< largest relative Eq. 15 difference on the check points, > 0
  int check_points = 16;    ///< seeded uniform box points scored both ways at build, >= 1
  std::uint64_t check_seed = 47;
  /// 1 drops the second-order terms (for tests that must see the check fail), else 2.
  int order = 2;

  /// "" when valid, else the first bad field and its value.
  std::string validate() const;
};

/// The fast search fitness of one InsIdentificationProblem (Eq. 15 only).
class FastFitness {
 public:
  /// Builds the model at the box centre and checks it (see the top of this file). Throws
  /// std::invalid_argument on bad options, opt::EvaluationError when an exact run fails.
  FastFitness(const InsIdentificationProblem& exact, FastFitnessOptions options = {});

  /// Eq. 15 of the model for each candidate. Each candidate's sum is formed alone, in epoch
  /// order, so the value does not depend on the batch, its order or the thread count.
  void evaluate(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
                int threads = 1) const;
  /// The model's residual vector at x (dvE_0, dvN_0, ...), as the exact kernel orders it.
  std::vector<double> residuals(const Eigen::VectorXd& x) const;

  /// The check at build time: largest relative difference of Eq. 15 over the check points.
  double check_max_relative_difference() const { return check_max_relative_difference_; }
  /// True when the check passed (the search may use the model).
  bool usable() const { return check_max_relative_difference_ <= options_.tolerance; }
  const FastFitnessOptions& options() const { return options_; }
  int exact_runs_to_build() const { return exact_runs_; }
  std::size_t nodes() const { return node_epoch_.size(); }
  double build_s() const { return build_s_; }
  /// The build and its check, for result files.
  nlohmann::json to_json() const;

 private:
  void build(const InsIdentificationProblem& exact);
  // Eq. 15 of the model for candidates [k0, k0 + n) of xs (n <= kChunk).
  void evaluate_chunk(std::span<const Eigen::VectorXd> xs, std::size_t k0, std::size_t n,
                      std::span<double> f_out) const;

  FastFitnessOptions options_;
  int d_ = 0;               // estimated parameters
  int features_ = 0;        // d + d(d + 1)/2: dx_i, dx_i^2 / 2, dx_i dx_j (i < j)
  std::size_t epochs_ = 0;  // GNSS epochs compared
  Eigen::VectorXd centre_;  // normalised coordinates the model is taken at
  std::vector<double> r0_;  // r_t(c): dvE, dvN per epoch
  std::vector<double> w_;   // per epoch: interpolation weight between its block's two nodes
  std::vector<std::size_t> node_epoch_;         // epoch of each node
  std::vector<double> coeff_;                   // per node: J and H rows, east then north
  std::vector<batch_kernel::SumBlock> blocks_;  // epochs interpolated between two nodes
  int exact_runs_ = 0;
  double check_max_relative_difference_ = 0.0;
  double build_s_ = 0.0;
};

/// The problem the optimizers see: the fast fitness when asked for and usable, else the exact
/// kernel. Residual batches (LM) always come from the exact kernel; exact() is the problem every
/// reported number is scored with.
class SearchProblem final : public opt::Problem, public opt::ResidualProblem {
 public:
  SearchProblem(const InsIdentificationProblem& exact, SearchFitnessKind kind,
                FastFitnessOptions options = {});

  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f_out) const override;
  bool deterministic() const override { return true; }
  int residual_count() const override { return exact_.residual_count(); }
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r_out,
                               std::span<double> f_out) const override {
    exact_.evaluate_residual_batch(xs, r_out, f_out);
  }
  std::string name() const override { return exact_.name(); }

  const InsIdentificationProblem& exact() const { return exact_; }
  SearchFitnessKind requested() const { return requested_; }
  /// True when the fast model scores the search's candidates.
  bool uses_fast() const { return fast_ && fast_->usable(); }
  /// "fast" or "exact": what scored the search's candidates.
  std::string_view used() const { return uses_fast() ? "fast" : "exact"; }
  /// Exact Eq. 15 of each point (the reported numbers).
  std::vector<double> exact_fitness(std::span<const Eigen::VectorXd> xs) const;
  /// {"requested", "used", "reported": "exact", "fast": the build and check, "reason" when the
  /// fast fitness was asked for and not used}.
  nlohmann::json to_json() const;

 private:
  const InsIdentificationProblem& exact_;
  SearchFitnessKind requested_;
  std::unique_ptr<FastFitness> fast_;
  std::string reason_;
};

}  // namespace insid
