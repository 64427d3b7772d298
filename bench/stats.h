// Statistics for comparing optimizers over repeated seeds: descriptives, the two-sided
// Mann-Whitney U test, Holm-Bonferroni correction, the Vargha-Delaney A12 effect size,
// COCO's expected running time (aRT), the Friedman test and a bootstrap CI of the median.
//
// Every function validates its input and throws std::invalid_argument naming the function
// and the problem (empty sample, NaN at index i, ragged table, ...). Infinities are accepted
// (a run that diverged may legitimately report an infinite fitness); NaN never is.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "base/enum_table.h"

namespace insid::stats {

// ---------------------------------------------------------------------------------------------
// Descriptives
// ---------------------------------------------------------------------------------------------

/// Quantile of type 7 (Hyndman & Fan 1996): linear interpolation between order statistics at
/// h = (n - 1) q, identical to numpy.quantile(x, q) with its default method='linear'.
/// q in [0, 1].
double quantile(const std::vector<double>& x, double q);

/// quantile(x, 0.5): numpy.quantile(x, 0.5) exactly, numpy.median(x) up to the last bit.
double median(const std::vector<double>& x);

/// First quartile, median and third quartile (all type 7).
struct Quartiles {
  double q1 = 0.0;
  double median = 0.0;
  double q3 = 0.0;
  double iqr() const { return q3 - q1; }
};
Quartiles quartiles(const std::vector<double>& x);

/// Interquartile range q3 - q1 (type 7).
double iqr(const std::vector<double>& x);

// ---------------------------------------------------------------------------------------------
// Two-sided Mann-Whitney U test
// ---------------------------------------------------------------------------------------------

enum class MannWhitneyMethod {
  kAuto,   ///< exact when there are no ties and min(n1, n2) <= 8 (scipy's rule), else asymptotic
  kExact,  ///< exact null distribution; throws if there are ties or C(n1+n2, n1) >= 2^63
  kAsymptotic,  ///< normal approximation with tie correction and continuity correction
};

/// The names written to summary.json's "method".
inline constexpr EnumTable<MannWhitneyMethod, 3> kMannWhitneyMethodNames{
    "Mann-Whitney method",
    {{{MannWhitneyMethod::kAuto, "auto"},
      {MannWhitneyMethod::kExact, "exact"},
      {MannWhitneyMethod::kAsymptotic, "asymptotic"}}}};
inline std::string_view to_string(MannWhitneyMethod method) {
  return kMannWhitneyMethodNames.name(method);
}

struct MannWhitneyResult {
  double u = 0.0;  ///< U statistic of sample a: R_a - n_a (n_a + 1) / 2 (scipy's statistic)
  double p = 1.0;  ///< two-sided p-value, in [0, 1]
  MannWhitneyMethod method = MannWhitneyMethod::kAsymptotic;  ///< the method actually used
  double z = 0.0;     ///< standardized statistic (asymptotic only; 0 for exact)
  bool ties = false;  ///< whether the pooled sample has ties
};

/// Two-sided Mann-Whitney U test of samples a and b, equal to
/// scipy.stats.mannwhitneyu(a, b, alternative='two-sided', use_continuity=True, method=...)
/// (scipy >= 1.7). kAuto falls back to the asymptotic method if the exact distribution would
/// overflow (only possible with min(n1, n2) <= 8 and max(n1, n2) in the thousands).
MannWhitneyResult mann_whitney_u(const std::vector<double>& a, const std::vector<double>& b,
                                 MannWhitneyMethod method = MannWhitneyMethod::kAuto);

// ---------------------------------------------------------------------------------------------
// Multiple comparisons
// ---------------------------------------------------------------------------------------------

/// Holm-Bonferroni step-down adjusted p-values, in the order of the input: with p sorted
/// ascending p_(1) <= ... <= p_(m), p~_(i) = min(1, max_{j <= i} (m - j + 1) p_(j)).
/// Equal to statsmodels' multipletests(p, method='holm')[1]. Each p must be in [0, 1].
/// An empty input gives an empty output.
std::vector<double> holm(const std::vector<double>& p);

// ---------------------------------------------------------------------------------------------
// Effect size
// ---------------------------------------------------------------------------------------------

/// Vargha-Delaney A12 = P(X_a > X_b) + 0.5 P(X_a = X_b), over all n_a n_b pairs
/// (Vargha & Delaney 2000, Eq. 14; equals U_a / (n_a n_b)). For fitness (lower is better) an
/// A12 below 0.5 means a tends to be better than b.
double a12(const std::vector<double>& a, const std::vector<double>& b);

enum class A12Magnitude { kNegligible, kSmall, kMedium, kLarge };

/// Vargha & Delaney (2000) thresholds, symmetric around 0.5: with d = |A12 - 0.5|,
/// negligible d < 0.06 (A12 in (0.44, 0.56)), small d < 0.14, medium d < 0.21, else large.
/// A12 must be in [0, 1].
A12Magnitude a12_magnitude(double a12_value);

inline constexpr EnumTable<A12Magnitude, 4> kA12MagnitudeNames{
    "A12 magnitude",
    {{{A12Magnitude::kNegligible, "negligible"},
      {A12Magnitude::kSmall, "small"},
      {A12Magnitude::kMedium, "medium"},
      {A12Magnitude::kLarge, "large"}}}};
inline std::string_view to_string(A12Magnitude magnitude) {
  return kA12MagnitudeNames.name(magnitude);
}

// ---------------------------------------------------------------------------------------------
// Expected running time (COCO)
// ---------------------------------------------------------------------------------------------

/// One run's outcome for one target.
struct RunOutcome {
  double evaluations = 0.0;  ///< evaluations used to reach the target, or the run's total if not
  bool reached = false;      ///< whether the run reached the target
};

struct RunningTime {
  double art = 0.0;           ///< sum of evaluations over all runs / successes; +inf if none
  double success_rate = 0.0;  ///< successes / runs
  std::size_t successes = 0;
  std::size_t runs = 0;
};

/// COCO's average running time aRT (Hansen et al., "COCO: performance assessment", 2016,
/// Eq. 2: aRT = (sum of evaluations of all runs, successful or not) / #successes).
/// Evaluations must be finite and >= 0; the vector must not be empty.
RunningTime expected_running_time(const std::vector<RunOutcome>& runs);

// ---------------------------------------------------------------------------------------------
// Friedman test
// ---------------------------------------------------------------------------------------------

struct FriedmanResult {
  double statistic = 0.0;          ///< tie-corrected chi-square statistic (NaN when undefined)
  double p = 0.0;                  ///< chi2(k - 1) survival at the statistic (NaN when undefined)
  std::vector<double> mean_ranks;  ///< per treatment, rank 1 = smallest value within a block
  std::size_t blocks = 0;
  std::size_t treatments = 0;
  std::string note;  ///< why p is NaN (fewer than 2 blocks or treatments, all blocks tied)
};

/// Friedman test: table[block][treatment], e.g. blocks = scenarios and treatments =
/// algorithms with each cell the median final fitness. Ranks within each block with ties
/// averaged; chi2 = (12 / (n k (k + 1)) sum_j R_j^2 - 3 n (k + 1)) / C with the tie
/// correction C = 1 - sum (t^3 - t) / (n k (k^2 - 1)); identical to
/// scipy.stats.friedmanchisquare(*columns) for k >= 3 (scipy refuses k = 2; here it is
/// allowed). Mean ranks are always filled; with fewer than 2 blocks or 2 treatments the
/// statistic and p are NaN with a note. The table must be rectangular, non-empty, without NaN.
FriedmanResult friedman(const std::vector<std::vector<double>>& table);

// ---------------------------------------------------------------------------------------------
// Bootstrap
// ---------------------------------------------------------------------------------------------

struct ConfidenceInterval {
  double estimate = 0.0;  ///< the sample statistic (here the median)
  double lo = 0.0;
  double hi = 0.0;
  double level = 0.95;
};

/// Percentile bootstrap CI of the median: `resamples` resamples with replacement drawn with
/// std::mt19937_64(seed) and an unbiased rejection-sampled index (no std::uniform_int_
/// distribution, whose output is implementation-defined), so the interval is the same on
/// every platform. lo / hi are the type-7 quantiles (1 - level) / 2 and (1 + level) / 2 of the
/// resampled medians. level in (0, 1), resamples >= 1.
ConfidenceInterval bootstrap_median_ci(const std::vector<double>& x, double level = 0.95,
                                       std::size_t resamples = 2000, std::uint64_t seed = 1);

/// Uniform integer in [0, n) from a 64-bit word source, by rejection (portable; exposed for
/// tests). n >= 1.
template <class Engine>
std::uint64_t uniform_index(Engine& engine, std::uint64_t n) {
  // Largest multiple of n representable: accept words below it so every index is equally likely.
  const std::uint64_t limit = UINT64_MAX - (UINT64_MAX % n + 1) % n;
  for (;;) {
    const std::uint64_t w = engine();
    if (w <= limit) return w % n;
  }
}

}  // namespace insid::stats
