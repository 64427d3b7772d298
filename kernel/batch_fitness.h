// Batched multi-candidate fitness kernel (docs/design.md sec. 2 "Per-candidate pipeline",
// sec. 8). K candidates advance in lock-step over the shared IMU/GNSS stream of one
// NavigationProblem, one SIMD lane per candidate (structure of arrays, 8 doubles per vector,
// 2 vectors advanced together so that two independent dependency chains hide latency).
//
// Every lane does what NavigationProblem::run does for its candidate: compensation with the
// general IMU error model (bias, bias drift, scale, misalignment), per-candidate alignment in
// O(1) from the window sums, two-sample coning/sculling, height aiding, the antenna lever arm,
// GNSS latency (epoch bracketing per candidate) and Eq. 15 / sum-of-squares accumulation;
// optionally the residual vector; the windowed fitness (NavigationOptions::window_s: every lane
// restarted at the problem's restart epochs from the GNSS solution shifted by its latency, less
// its lever arm, nav/fitness.h). Results equal the scalar reference up to floating-point
// rounding (the kernel reassociates some arithmetic and evaluates the Earth model by series about
// exactly computed values instead of libm calls; see batch_fitness.cc).
//
// Determinism: a lane's arithmetic never depends on the other lanes, on how candidates are
// grouped into vectors or on the thread count, so results are bit-identical for any batching.
#pragma once

#include <exception>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kernel/batch_lanes.h"
#include "model/sensor_errors.h"
#include "nav/fitness.h"

namespace insid {

class BatchFitness {
 public:
  static constexpr int kLanes = kBatchLanes;  ///< doubles per SIMD vector (batch_lanes.h)
  static constexpr int kMaxChains = 2;        ///< vectors advanced together in one group, at most
  /// Vectors per group that `evaluate` plans on the program's instruction-set path
  /// (kernel/cpu_path.h): two with AVX-512's 32 registers; one on the AVX2 and baseline paths,
  /// where a vector takes 2 or 4 of 16 registers and a two-vector group spills.
  static int planned_chains();

  /// Precomputes what the kernel needs (O(data), a few milliseconds per hour of data).
  explicit BatchFitness(std::shared_ptr<const NavigationProblem> problem);
  /// One kernel per NavigationProblem, shared by everyone who asks while it is alive.
  static std::shared_ptr<const BatchFitness> shared(
      const std::shared_ptr<const NavigationProblem>& problem);

  const NavigationProblem& problem() const { return *problem_; }
  /// False when the data are outside what the kernel's series cover (a body rotation of more
  /// than 0.2 rad in one IMU interval, non-increasing IMU time stamps, no alignment window);
  /// callers then use the scalar reference. unsupported_reason() says why.
  bool supported() const { return reason_.empty(); }
  const std::string& unsupported_reason() const { return reason_; }

  struct Request {
    std::span<const SensorErrors> candidates;
    std::span<double> fitness;  ///< one slot per candidate (NaN for a failed candidate)
    FitnessKind kind = FitnessKind::kEq15;
    /// Empty, or one vector per candidate: resized to 2 * num_epochs and filled with the
    /// residuals (dvE_0, dvN_0, ...) exactly as NavigationProblem::residuals orders them.
    std::span<std::vector<double>> residuals;
    /// OpenMP threads across groups of vectors (1 = the calling thread only).
    int threads = 1;
    /// Empty: the lowest-index candidate whose set-up failed (e.g. an alignment that throws)
    /// is rethrown after the others are done. Else one slot per candidate: failures land here.
    std::span<std::exception_ptr> errors;
    /// Empty: the program's instruction-set path (kernel/cpu_path.h, chosen at first use). Else
    /// the named path (avx512, avx2, baseline, native), which the program must hold and the CPU
    /// run: tests run every path the CPU has this way.
    std::string_view cpu_path;
  };
  /// Scores every candidate. Throws std::invalid_argument on size mismatches or when the data
  /// are not supported().
  void evaluate(const Request& request) const;
  /// Convenience: fitness of each candidate (on the named instruction-set path: Request's
  /// cpu_path).
  std::vector<double> fitness(std::span<const SensorErrors> candidates,
                              FitnessKind kind = FitnessKind::kEq15, int threads = 1,
                              std::string_view cpu_path = {}) const;

  /// How `evaluate` packs `num_vectors` SIMD vectors into groups (each of 1..planned_chains()
  /// vectors) for `threads` threads. Grouping never changes a result; exposed for tests.
  static std::vector<int> plan_groups(int num_vectors, int threads);
  /// Evaluates with an explicit grouping (vectors per group, summing to ceil(K / kLanes)):
  /// for tests of grouping invariance.
  void evaluate_grouped(const Request& request, const std::vector<int>& groups) const;

  struct Impl;  ///< precomputed data (batch_fitness.cc)

 private:
  std::shared_ptr<const NavigationProblem> problem_;
  std::shared_ptr<const Impl> impl_;
  std::string reason_;
};

}  // namespace insid
