// The identification pipeline as one library call: identify(spec) ->
// report, as run_diagnose is for `insid diagnose`. `insid identify` only maps its arguments to
// an IdentifySpec (identification/identify.h) and writes the report; the mems study runs its
// swarm through it. Ceres' Solve(options, problem, &summary) is the model.
//
// The pipeline: the dataset (loaded from spec.data_dir unless given), the grade and window
// settled (identify_setup: the default parameter set, the gyro bias allowance), the Eq. 15
// problem, the optimizer's ask / evaluate / tell loop with progress, then the result JSON: the
// optimizer's history, the settings, the data's own optimum (cached in data_dir), the
// assessment against the truth and the optimum, the uncertainty (identification/uncertainty.h)
// and the autopilot's own estimates when the import recorded them.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "identification/identify.h"
#include "identification/uncertainty.h"
#include "optimizers/optimizer.h"

namespace insid {

/// Where a run tells how it goes; any of them may be empty (quiet).
struct IdentifyProgress {
  /// A line to keep: the grade and window, how the optimizer stopped, the optimum's computation.
  std::function<void(const std::string&)> note;
  /// A line that replaces the previous one: the iteration, evaluations and best so far.
  std::function<void(const std::string&)> status;
  /// The status lines are over (before the closing note).
  std::function<void()> finish;
};

struct IdentifyReport {
  /// The insid-identify/2 result (results/README.md), as `insid identify` writes it.
  nlohmann::json result;
  /// The human tables `insid identify` prints on stderr after the run (the uncertainty, the
  /// comparison with the autopilot); empty when there is neither.
  std::string tables;
  /// The run's settings on its dataset (grade, window, estimated parameters, navigation).
  IdentifySetup setup;
  /// The optimizer's result (problem coordinates) and, when replicas were asked for, the
  /// uncertainty at its best point (what the result's "parameters" block is written from).
  opt::Result optimizer_result;
  std::optional<UncertaintyReport> uncertainty;
};

/// Runs `spec` (validated first: IdentifySpecError names a bad field; one that only the data
/// can refuse, such as an --estimate box or an optimizer parameter, is named the same way).
/// Other errors of the data (an unreadable dataset, a refused gyrocompass) are thrown as they
IdentifyReport identify(const IdentifySpec& spec, const IdentifyProgress& progress = {});

}  // namespace insid
