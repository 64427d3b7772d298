// One identification run on a dataset: optimizer over the INS problem, then the result as JSON
// (estimate in SI and sigma units, errors against the injected truth and against the data's own
// optimum, history). Shared by `insid identify` and the campaign runner.
//
// What an identification is (IdentifySpec) and the rules every front end shares: the default
// parameter set of a grade (default_estimated) and the gyrocompass's gyro bias allowance
// (gyro_bias_allowance_rad_s). The run itself, identify(spec) -> report, is
// identification/identify_run.h (it reports the uncertainty, a library above this one).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "identification/box_widening.h"
#include "identification/grade.h"
#include "identification/ins_problem.h"
#include "identification/local_fit.h"
#include "identification/search_fitness.h"
#include "kernel/build_info.h"  // build_info_json, recorded in every result
#include "nav/fitness.h"
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
/// `estimated[].sigma`: the catalogue sigma unless given). kEstimateInSigmaUnitsOld is the name
/// insid-identify/1 and insid-run/1 records use, still read; it is not a standard deviation.
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

/// The parameters estimated when none are named (identify, diagnose, campaign configs): nav the
/// paper's four at the catalogue's sigmas, as always; tactical and mems the x/y accelerometer and
/// x/y/z gyro biases at the grade's sigmas (the z gyro is observable once the heading comes from
/// the GNSS course or the flight turns; the uncertainty flags it not_observable when it is not).
std::vector<EstimatedParameter> default_estimated(const SensorGrade& grade);

/// The parameters of an identification: each NAME[:SIGMA[:LO:HI]] of `estimate` with the grade's
/// sigma as the unit of a NAME given alone (SensorGrade::parameter), or the grade's
/// default_estimated when `estimate` is empty. Throws std::invalid_argument naming a bad item.
std::vector<EstimatedParameter> identify_parameters(const SensorGrade& grade,
                                                    const std::vector<std::string>& estimate);

/// The gyro bias the gyrocompass feasibility check must allow for (nav/alignment.h,
/// InitialAttitudeOptions::gyro_bias_allowance_rad_s) when `estimated` are searched: the
/// largest |box edge| (rad/s) of the estimated horizontal gyro biases (gyro_bias_x, gyro_bias_y:
/// the east gyro error is what tilts a gyrocompass heading), else the catalogue sigma (the data
/// are then taken as compensated, as navigate does). Before the identification the bias can be
/// anywhere in that box, so a heading refused for it would be refused for the answer too.
///
/// The one rule of identify and campaigns, whether or not a campaign's config names
/// "initial_attitude": a tactical or MEMS box (4 deg/h, 0.4 deg/s) is checked against its own
/// edges, never the catalogue's 0.01 deg/h, so a campaign gyrocompasses exactly the data
/// `insid identify` accepts. (A zero edge cannot occur: EstimatedParameter::parse requires
/// sigma > 0 and LO < HI.)
double gyro_bias_allowance_rad_s(const std::vector<EstimatedParameter>& estimated);

/// A field of an IdentifySpec that cannot be run. what() names the field first (the spec's name,
/// e.g. "uncertainty_replicas 5: ...") unless the message of the parser it came from names the
/// command-line option already ("--estimate 'x': ..."); field() lets a front end name its own
/// option instead.
class IdentifySpecError : public std::invalid_argument {
 public:
  IdentifySpecError(std::string field, const std::string& what)
      : std::invalid_argument(what), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

/// One identification of a dataset (`insid identify`, identify_run.h): what to estimate, with
/// which optimizer and budget, and how to navigate. The defaults are `insid identify`'s.
struct IdentifySpec {
  /// The dataset directory: loaded unless `dataset` is given, recorded as "data", and where the
  /// data's own optimum is cached (cached_reference_optimum).
  std::string data_dir;
  /// The data of data_dir already loaded (optional: a study's simulated flight has no directory
  /// and no reference optimum, see `reference_optimum`).
  std::shared_ptr<const Dataset> dataset;
  /// ga | pso | pio | dvpio | a reference baseline | external:CMD (optimizers/registry.h).
  std::string algorithm = "dvpio";
  /// NAME[:SIGMA[:LO:HI]] (SIGMA in SI, box in sigma units; NAME alone: the grade's sigma);
  /// empty: default_estimated(grade).
  std::vector<std::string> estimate;
  /// auto | nav | tactical | mems (identification/grade.h; auto: choose_grade on the data).
  std::string grade = "auto";
  /// KEY=VALUE algorithm parameters; distances with the suffix _sigma in sigma units
  /// (algorithm_params_in_box).
  std::vector<std::string> params;
  std::uint64_t seed = 1;
  int iterations = 40;           ///< iteration budget (0 = none)
  std::int64_t evaluations = 0;  ///< evaluation budget (0 = none)
  AlignmentMode alignment = AlignmentMode::kPerCandidate;
  /// Fitness window (s, nav/fitness.h); absent: the grade's default (default_window_s).
  std::optional<double> window_s;
  /// How the attitude at the navigation start is found; its gyro_bias_allowance_rad_s is not
  /// read: the run sets it from the search box (gyro_bias_allowance_rad_s).
  InitialAttitudeOptions initial_attitude;
  int threads = 0;  ///< OpenMP threads (0 = all, 1 = serial)
  /// Find (or read from data_dir's cache) the data's own optimum and judge the run against it.
  bool reference_optimum = true;
  bool record_positions = false;   ///< every particle's position per iteration
  int uncertainty_replicas = 100;  ///< 0: no uncertainty; else at least 10 noise replicas
  /// An estimate at an edge of its box widens the box and runs the search again, up to the
  /// grade's physical limits (identification/box_widening.h); off: the box stays as given.
  BoxWideningOptions box_widening;
  /// The gyro biases measured at rest over the static window (nav/gyro_at_rest.h) instead of
  /// searched: gyro_bias_x|y|z leave the default set and may not be named in `estimate`; what
  /// the flight sees beyond them (a motor offset) is then told apart from them.
  bool gyro_bias_at_rest = false;
  /// What steers the search (identification/search_fitness.h): the fast second-order model when
  /// its check passes, or the exact kernel. The exact kernel scores every reported number either
  /// way; lm and ekf-rts always run on it.
  SearchFitnessKind search_fitness = SearchFitnessKind::kFast;

  /// "" when the spec can be run, else what is wrong, naming the bad field and value (the
  /// project's convention for options; spec_problem keeps the field for a front end): no data
  /// (neither data_dir nor dataset), an unknown algorithm or grade, an --estimate form that does
  /// not parse, a param not KEY=VALUE with a finite value, a negative budget or both budgets 0,
  /// a window that is not a finite number >= 0, negative threads, 1-9 uncertainty replicas,
  /// invalid initial-attitude options. What depends on the data (the grade's sigma, the
  /// optimizer's own parameter names) is checked by the run.
  std::string validate() const;
};

/// validate()'s check with the field kept: the first invalid field of `spec` as an error
/// (field() and what()), none when it can be run. identify() throws it; `insid identify` turns
/// it into a usage error naming its own option.
std::optional<IdentifySpecError> spec_problem(const IdentifySpec& spec);

/// What an IdentifySpec comes to on its dataset: the grade and window settled, the estimated
/// parameters and the navigation options (the gyro bias allowance set from the box).
struct IdentifySetup {
  GradeAndWindow settled;
  const SensorGrade* grade = nullptr;
  std::vector<EstimatedParameter> estimated;
  NavigationOptions navigation;
};
/// Throws IdentifySpecError for a bad --estimate item (after validate(), only one whose box
/// leaves the catalogue's range at the grade's sigma).
IdentifySetup identify_setup(const IdentifySpec& spec, const Dataset& dataset);

/// KEY=VALUE algorithm parameters; NAME_sigma for a distance parameter NAME of the algorithm
/// (`own`, its opt::parameter_info) is that distance in sigma units, converted to the
/// normalised box of `mapping` (ParameterMapping::algorithm_parameter_in_box). A key given
/// twice: the last one counts. Throws IdentifySpecError (field "params") naming the item.
opt::ParameterMap algorithm_params_in_box(const std::vector<std::string>& items,
                                          const ParameterMapping& mapping,
                                          const opt::ParameterInfoList& own);

}  // namespace insid
