#include "optimizers/fitness_memo.h"

#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace insid::opt {

FitnessMemo::FitnessMemo(std::size_t generation_size) : generation_size_(generation_size) {
  if (generation_size_ == 0)
    throw std::invalid_argument("FitnessMemo: generation_size must be >= 1, got 0");
}

FitnessMemo::Key FitnessMemo::key_of(const Eigen::VectorXd& x) {
  return Key(reinterpret_cast<const char*>(x.data()),
             static_cast<std::size_t>(x.size()) * sizeof(double));
}

const double* FitnessMemo::find(const Key& key) {
  if (const auto it = current_.find(key); it != current_.end()) return &it->second;
  const auto it = previous_.find(key);
  if (it == previous_.end()) return nullptr;
  const double fitness = it->second;
  previous_.erase(it);
  remember(key, fitness);
  return &current_.find(key)->second;
}

void FitnessMemo::remember(Key key, double fitness) {
  if (current_.size() >= generation_size_) {
    previous_ = std::move(current_);
    current_.clear();
  }
  current_.emplace(std::move(key), fitness);
}

std::size_t FitnessMemo::evaluate_batch(const Problem& problem, std::span<const Eigen::VectorXd> xs,
                                        std::span<double> f_out) {
  if (f_out.size() != xs.size())
    throw std::invalid_argument("FitnessMemo: " + std::to_string(xs.size()) + " candidates but " +
                                std::to_string(f_out.size()) + " fitness slots");
  if (!problem.deterministic())
    throw std::logic_error("FitnessMemo: problem '" + problem.name() + "' is not deterministic()");
  if (problem_ == nullptr) problem_ = &problem;
  if (problem_ != &problem)
    throw std::logic_error("FitnessMemo: problem '" + problem.name() +
                           "' is not the one this memo was filled by ('" + problem_->name() + "')");
  // Each candidate: its known fitness, or the index of its distinct unknown point.
  constexpr std::size_t kKnown = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> slot(xs.size(), kKnown);
  std::vector<Key> keys;
  std::vector<Eigen::VectorXd> unknown;
  std::unordered_map<Key, std::size_t> first;  // key -> index into `unknown`
  for (std::size_t i = 0; i < xs.size(); ++i) {
    Key key = key_of(xs[i]);
    if (const double* known = find(key)) {
      f_out[i] = *known;
      continue;
    }
    const auto [it, inserted] = first.emplace(key, unknown.size());
    if (inserted) {
      unknown.push_back(xs[i]);
      keys.push_back(std::move(key));
    }
    slot[i] = it->second;
  }
  if (unknown.empty()) return 0;
  std::vector<double> f_unknown(unknown.size(), std::numeric_limits<double>::quiet_NaN());
  try {
    problem.evaluate_batch(unknown, f_unknown);
  } catch (...) {
    // Again as one batch: the problem's error then names the candidate by its index in xs.
    problem.evaluate_batch(xs, f_out);
    throw;
  }
  for (std::size_t i = 0; i < xs.size(); ++i)
    if (slot[i] != kKnown) f_out[i] = f_unknown[slot[i]];
  for (std::size_t u = 0; u < unknown.size(); ++u) remember(std::move(keys[u]), f_unknown[u]);
  return unknown.size();
}

}  // namespace insid::opt
