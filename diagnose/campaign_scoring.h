// How a hidden-effect case of the diagnose campaign (tools/diagnose_campaign.cc) stands
// against what its flight can tell, from the case's own committed row: no flight is re-run.
//
// *Detectable*: the injected size is at least the truth's minimum detectable size
// estimated ALONE, (threshold + 1.645) x sd of its one-at-a-time estimate (95 % power, the first
// iteration's row `hidden_rows[truth]`).
// *Separable* (the second scoring): the injected size is at least the minimum detectable
// size when the truth is estimated JOINTLY with its most correlated recorded collinear partner: the
// alone size times 1 / sqrt(1 - rho^2), rho the largest |correlation| in the row's `collinear` list
// (the correlation of the two projected whitened columns in diagnose's working metric). With one
// partner this is exactly the GLS sd inflation of the working model; with several it is a lower
// bound of the inflation with the whole class (the multiple R^2 on all partners is at least the
// largest single rho^2), and partners at |rho| <= diagnose's collinear_threshold (0.95) are not
// recorded at all (an unrecorded partner could still inflate the sd by up to 3.2x). So
// "separable" errs towards calling a case separable. `class_inflation` gives the inflation with
// the whole recorded class where all its mutual correlations are recorded, as a check. The sd
// inflated is the replica-calibrated sd of the one-at-a-time estimate, the correlation that of
// the working covariance (diagnose/README.md steps 2 and 5): the replicas' own joint sd may
// inflate differently. "Not separable" means the flight does not promise 95 % power at the
// family-wise threshold for the joint estimate, not that it cannot name the truth.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace insid::diagnose {

struct CaseLimits {
  bool has_row = false;         ///< the case holds the truth's first-iteration row
  double min_detectable = 0.0;  ///< SI, the truth estimated alone (95 % power)
  std::string partner;          ///< the most correlated recorded collinear partner ("" if none)
  double partner_correlation = 0.0;  ///< its |correlation| (0 if none)
  double inflation = 1.0;            ///< 1 / sqrt(1 - rho^2): joint sd over the alone sd
  double min_separable = 0.0;        ///< SI, min_detectable x inflation (infinite at |rho| = 1)
  bool detectable = true;  ///< observable and |injected| >= min_detectable (true without a row)
  bool separable = true;   ///< detectable and |injected| >= min_separable (true without a row)
};

/// The limits of one case from the truth's first-iteration candidate row (`hidden_rows[truth]`:
/// min_detectable_sigma, sd, sd_sigma, observable, collinear[].correlation) and the injected SI
/// value. A null row (a campaign that recorded no hidden_rows) gives has_row false, detectable and
/// separable.
CaseLimits case_limits(const nlohmann::json& truth_row, double injected);

/// sqrt((R^-1)_00) for R the correlation matrix of the truth and all its recorded collinear
/// partners (from the first iteration's candidate table, `first_candidates`), i.e. the joint sd
/// over the alone sd with the whole recorded class; NaN when a mutual correlation of two class
/// members is not recorded (below the collinear threshold), when the truth has no row, or when R
/// is not positive definite. 1 without partners.
double class_inflation(const nlohmann::json& first_candidates, const std::string& truth);

/// What the first name says about the truth.
enum class FirstName {
  kNothing,            ///< nothing named
  kTruth,              ///< the truth named first
  kTruthInFlaggedSet,  ///< another effect named first, flagged ambiguous with the truth
  kWrongFlagged,       ///< a wrong effect first, flagged ambiguous (with others, not the truth)
  kWrongUnflagged,     ///< a wrong effect first, no ambiguity flag
};
FirstName first_name(const nlohmann::json& found, const std::string& truth);

}  // namespace insid::diagnose
