// Portable random numbers for the optimizers.
//
// Every draw of a run comes from one std::mt19937_64 seeded from the run's seed. The engine's
// output sequence is fixed by the C++ standard; the transforms to real numbers are written
// here (std::uniform_real_distribution and friends are implementation-defined), so a seed
// gives the same run with any standard library. Optimizers draw only in ask()/tell(), never
// inside an evaluation, so results do not depend on evaluation order or thread count.
#pragma once

#include <cstdint>
#include <random>

namespace insid::opt {

/// SplitMix64 finaliser: spreads nearby seeds (0, 1, 2, ...) over the engine's state space.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// A seed for the k-th independent stream of a run seeded with `seed` (a splitmix64-style
/// finaliser of seed and k): replicas, restarts and iterations draw from mix_seed(seed, k).
inline std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t k) {
  std::uint64_t x = seed * 0x9e3779b97f4a7c15ULL + k + 0x632be59bd9b4e019ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(splitmix64(seed)) {}

  /// 64 random bits.
  std::uint64_t bits() { return engine_(); }

  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(bits() >> 11) * 0x1.0p-53; }

  /// Uniform in [low, high).
  double uniform(double low, double high) { return low + (high - low) * uniform(); }

  /// Uniform integer in [0, n), n > 0, without modulo bias (rejection sampling).
  std::uint64_t below(std::uint64_t n) {
    const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;  // multiple of n
    std::uint64_t x = bits();
    while (x >= limit) x = bits();
    return x % n;
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace insid::opt
