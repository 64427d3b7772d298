// One identification run on a dataset: optimizer over the INS problem, then the result as JSON
// (estimate in SI and sigma units, errors against the injected truth and against the data's own
// optimum, history). Shared by `insid identify` and the campaign runner.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/build_info.h"  // build_info_json, recorded in every result
#include "core/dataset.h"
#include "core/fitness.h"
#include "identification/ins_problem.h"
#include "identification/local_fit.h"
#include "optimizers/optimizer.h"
#include "optimizers/parameters.h"

namespace insid {

/// The data's own optimum: best of a multi-start local fit (LM + Eq. 15 IRLS), docs/design.md
/// sec. 10: judge an optimizer against it, and the truth against the noise floor.
struct ReferenceOptimum {
  Eigen::VectorXd value_sigma;
  double fitness = 0.0;
  std::int64_t evaluations = 0;
  int starts = 0;
  nlohmann::json to_json(const ParameterMapping& mapping) const;
  /// Inverse of to_json (reads the estimate under its old name "estimate_sigma" too); throws
  /// nlohmann::json::exception on a missing or mistyped field, std::runtime_error when the
  /// estimate block is missing.
  static ReferenceOptimum from_json(const nlohmann::json& j, const ParameterMapping& mapping);
};

/// Multi-start local fit from the box centre and `starts - 1` seeded random points, the starts
/// in lock-step (local_fits: one batch a round for all of them, scored with the problem's own
/// parallelism; their linear algebra on up to `threads` threads). The result does not depend on
/// `threads` or on the problem's thread count.
constexpr int kReferenceOptimumStarts = 4;
constexpr std::uint64_t kReferenceOptimumSeed = 12345;
ReferenceOptimum find_reference_optimum(const InsIdentificationProblem& problem,
                                        int starts = kReferenceOptimumStarts,
                                        std::uint64_t seed = kReferenceOptimumSeed,
                                        int threads = 1);

/// Cached reference optimum in `<data_dir>/insid-optimum-cache.json` (extra files in a dataset
/// directory are ignored by the format), keyed by the data files' SHA-256 (dataset_digest),
/// estimated parameters, alignment and fixed effects.
/// Computed and stored when missing; a read-only directory only costs the recomputation.
/// `note` (empty: silent, for --quiet) is told when the optimum has to be computed, and when it
/// could not be cached.
ReferenceOptimum cached_reference_optimum(const std::string& data_dir,
                                          const InsIdentificationProblem& problem,
                                          const std::function<void(const std::string&)>& note = {});

/// Parameters of an optimizer result in JSON: history per iteration and per evaluation, with
/// DVPIO's d vector converted to sigma units through the mapping.
nlohmann::json optimizer_result_json(const opt::Result& result, const ParameterMapping& mapping,
                                     bool include_per_evaluation = true);

/// Name of the block that holds an estimate in sigma units (the search unit of each parameter,
/// `estimated[].sigma`: the catalogue sigma unless given). Before insid-identify/2 and
/// insid-run/2 it was "estimate_sigma", which readers took for a standard deviation (issue 15).
inline constexpr const char* kEstimateInSigmaUnits = "estimate_in_sigma_units";
inline constexpr const char* kEstimateInSigmaUnitsOld = "estimate_sigma";

/// The estimate in sigma units from a result / optimum block, under either name (old files);
/// throws std::runtime_error naming both when neither is there, nlohmann::json::exception on a
/// missing parameter or mistyped value.
Eigen::VectorXd estimate_in_sigma_units(const nlohmann::json& block,
                                        const ParameterMapping& mapping);

/// Estimate / error blocks: "estimate" (SI), "estimate_in_sigma_units", and with `injected`,
/// "truth_sigma" and "error_sigma" (estimate minus truth, sigma units).
void add_estimate_json(nlohmann::json& out, const ParameterMapping& mapping,
                       const Eigen::VectorXd& value_sigma,
                       const std::optional<std::map<std::string, double>>& injected);

/// The assessment of a run's best point, the part of the record that `insid identify` and
/// campaign run files share (results/README.md), built here for both: add_estimate_json's
/// blocks for result.best_x and, when the data's own optimum is known,
/// "error_vs_optimum_sigma" (estimate minus optimum, sigma units), "optimum_fitness",
/// "fitness_gap" (f - f_opt) and "fitness_gap_relative" ((f - f_opt) / f_opt).
void add_run_assessment_json(nlohmann::json& out, const opt::Result& result,
                             const ParameterMapping& mapping,
                             const std::optional<std::map<std::string, double>>& injected,
                             const ReferenceOptimum* optimum);

}  // namespace insid
