// Scores a repeated candidate once, for a problem whose fitness is a function of the candidate's
// bits (Problem::deterministic()).
//
// Swarm runs ask for the same point again more often than one would think: a GA child that was
// neither crossed nor mutated is a copy of its parent (0.5 x 0.8^n of them with the defaults),
// and once a PIO or DVPIO swarm has collapsed, pigeons whose velocity has decayed below the ulp of
// their position stand still at X_gbest while DVPIO's probes return to the same d. In the
// paper-fig9 campaign (4 seeds) 21 % of the GA's candidates repeat one scored earlier and 52 %
// of DVPIO's repeat one of the same or an earlier round. Their fitness is the value the problem
// gave the first time, bit for bit, so a run's result does not change; only the scoring is
// skipped.
//
// Memory is bounded: two generations of at most `generation_size` entries each. When the current
// one is full it becomes the previous one (the older is dropped); a candidate found in the
// previous generation moves to the current one.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <unordered_map>

#include <Eigen/Core>

#include "optimizers/problem.h"

namespace insid::opt {

class FitnessMemo {
 public:
  /// Entries per generation: 2^17 (about 13 MB each for 4-dimensional candidates).
  static constexpr std::size_t kDefaultGenerationSize = std::size_t{1} << 17;

  /// Throws std::invalid_argument when generation_size is 0.
  explicit FitnessMemo(std::size_t generation_size = kDefaultGenerationSize);

  /// f_out[i] = the fitness of xs[i] (f_out.size() == xs.size()): the distinct candidates not
  /// known yet are scored in one problem.evaluate_batch() call, in the order they first appear,
  /// the others are taken from the memo. Returns how many were scored. The problem must be
  /// deterministic(), and the same problem at every call (std::logic_error otherwise: the memo
  /// of one problem says nothing of another). When the scoring throws, the whole batch is scored
  /// again as problem.evaluate_batch(xs, f_out) so that the error names the candidate by its index
  /// in `xs`; nothing is remembered from a batch that threw.
  std::size_t evaluate_batch(const Problem& problem, std::span<const Eigen::VectorXd> xs,
                             std::span<double> f_out);

  /// Candidates remembered (both generations).
  std::size_t size() const { return current_.size() + previous_.size(); }

 private:
  // The candidate's bytes: 0.0 and -0.0 (and NaN payloads) are different candidates, as they
  // may score differently.
  using Key = std::string;
  static Key key_of(const Eigen::VectorXd& x);
  const double* find(const Key& key);
  void remember(Key key, double fitness);

  std::size_t generation_size_;
  const Problem* problem_ = nullptr;  // the problem of the first call
  std::unordered_map<Key, double> current_, previous_;
};

}  // namespace insid::opt
