#include "bench/stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>

namespace insid::stats {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

[[noreturn]] void fail(std::string_view function, const std::string& what) {
  std::ostringstream os;
  os << "insid::stats::" << function << ": " << what;
  throw std::invalid_argument(os.str());
}

// Rejects an empty sample or a NaN; `what` names the sample in the message ("sample a").
void check_sample(std::string_view function, const std::vector<double>& x,
                  std::string_view what = "sample") {
  if (x.empty()) fail(function, std::string(what) + " is empty");
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (std::isnan(x[i])) {
      fail(function, std::string(what) + " contains NaN at index " + std::to_string(i));
    }
  }
}

// numpy's _lerp (numpy/lib/function_base.py), reproduced so that quantile() matches
// numpy.quantile to the last bit: a + (b - a) t, evaluated from the nearer end.
double lerp(double a, double b, double t) {
  const double diff = b - a;
  return t >= 0.5 ? b - diff * (1.0 - t) : a + diff * t;
}

// Type-7 quantile of an already sorted, validated, non-empty sample.
double sorted_quantile(const std::vector<double>& sorted, double q) {
  const std::size_t n = sorted.size();
  const double h = static_cast<double>(n - 1) * q;
  const double lo_d = std::floor(h);
  const auto lo = static_cast<std::size_t>(lo_d);
  if (lo + 1 >= n) return sorted[n - 1];
  return lerp(sorted[lo], sorted[lo + 1], h - lo_d);
}

// Average ranks (1-based, ties get the mean of the ranks they span) and the sizes of the tie
// groups (only groups of size >= 2).
struct Ranking {
  std::vector<double> ranks;
  std::vector<std::size_t> tie_sizes;
};

Ranking average_ranks(const std::vector<double>& x) {
  const std::size_t n = x.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&x](std::size_t i, std::size_t j) { return x[i] < x[j]; });
  Ranking r;
  r.ranks.resize(n);
  std::size_t i = 0;
  while (i < n) {
    std::size_t j = i + 1;
    while (j < n && x[order[j]] == x[order[i]]) ++j;
    // Positions i..j-1 (0-based) hold ranks i+1..j: their mean is (i + 1 + j) / 2.
    const double rank = 0.5 * static_cast<double>(i + 1 + j);
    for (std::size_t k = i; k < j; ++k) r.ranks[order[k]] = rank;
    if (j - i >= 2) r.tie_sizes.push_back(j - i);
    i = j;
  }
  return r;
}

double tie_term(const std::vector<std::size_t>& tie_sizes) {
  double sum = 0.0;
  for (std::size_t t : tie_sizes) {
    const double td = static_cast<double>(t);
    sum += td * td * td - td;
  }
  return sum;
}

// C(m + n, m) in floating point, to decide whether exact counts fit in 64 bits.
double binomial_double(std::size_t m, std::size_t n) {
  double c = 1.0;
  for (std::size_t i = 1; i <= m; ++i) {
    c = c * static_cast<double>(n + i) / static_cast<double>(i);
  }
  return c;
}

constexpr double kExactCountLimit = 9.0e18;  // < 2^63, margin for the rounding of binomial_double

// Counts N(u) of arrangements of m "a" and n "b" values whose U statistic equals u, u = 0..mn:
// the coefficients of the Gaussian binomial [m + n choose m]_q
//   = prod_{i=1}^{m} (1 - q^{n+i}) / (1 - q^i)      (Andrews, The Theory of Partitions, 3.3).
// Each partial product [n + i choose i]_q is a polynomial with non-negative coefficients. The
// arithmetic is modulo 2^64 (unsigned wrap-around): multiplication by (1 - q^s) and division
// by (1 - q^i) (a unit in the power-series ring) are ring operations, so each coefficient comes
// out exact whenever the total C(m + n, m) < 2^64, which the caller checks.
std::vector<std::uint64_t> mwu_null_counts(std::size_t m, std::size_t n) {
  std::vector<std::uint64_t> c(1, 1);
  for (std::size_t i = 1; i <= m; ++i) {
    const std::size_t s = n + i;
    const std::size_t old_size = c.size();
    c.resize(old_size + s, 0);
    for (std::size_t j = c.size(); j-- > s;) c[j] -= c[j - s];    // times (1 - q^s)
    for (std::size_t j = i; j < c.size(); ++j) c[j] += c[j - i];  // divided by (1 - q^i)
    c.resize(i * n + 1);  // the top coefficients are now exactly zero
  }
  return c;
}

}  // namespace

// -------------------------------------------------------------------------------------------
// Descriptives
// -------------------------------------------------------------------------------------------

double quantile(const std::vector<double>& x, double q) {
  check_sample("quantile", x);
  if (!(q >= 0.0 && q <= 1.0)) fail("quantile", "q must be in [0, 1], got " + std::to_string(q));
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  return sorted_quantile(sorted, q);
}

double median(const std::vector<double>& x) {
  check_sample("median", x);
  return quantile(x, 0.5);
}

Quartiles quartiles(const std::vector<double>& x) {
  check_sample("quartiles", x);
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  return {sorted_quantile(sorted, 0.25), sorted_quantile(sorted, 0.5),
          sorted_quantile(sorted, 0.75)};
}

double iqr(const std::vector<double>& x) {
  check_sample("iqr", x);
  return quartiles(x).iqr();
}

// -------------------------------------------------------------------------------------------
// Mann-Whitney U
// -------------------------------------------------------------------------------------------

MannWhitneyResult mann_whitney_u(const std::vector<double>& a, const std::vector<double>& b,
                                 MannWhitneyMethod method) {
  check_sample("mann_whitney_u", a, "sample a");
  check_sample("mann_whitney_u", b, "sample b");
  const std::size_t n1 = a.size();
  const std::size_t n2 = b.size();
  const double n1d = static_cast<double>(n1);
  const double n2d = static_cast<double>(n2);

  std::vector<double> pooled = a;
  pooled.insert(pooled.end(), b.begin(), b.end());
  const Ranking ranking = average_ranks(pooled);
  const double r1 = std::accumulate(ranking.ranks.begin(), ranking.ranks.begin() + n1, 0.0);

  MannWhitneyResult result;
  result.u = r1 - n1d * (n1d + 1.0) / 2.0;  // U of sample a
  result.ties = !ranking.tie_sizes.empty();
  const double u1 = result.u;
  const double u2 = n1d * n2d - u1;
  const double u_max = std::max(u1, u2);  // two-sided: p = 2 P(U >= max(U1, U2))

  const bool exact_fits = binomial_double(std::min(n1, n2), std::max(n1, n2)) < kExactCountLimit;
  if (method == MannWhitneyMethod::kAuto) {
    // scipy's _mwu_choose_method, plus a fallback where exact counts would overflow.
    method = (std::min(n1, n2) <= 8 && !result.ties && exact_fits) ? MannWhitneyMethod::kExact
                                                                   : MannWhitneyMethod::kAsymptotic;
  }
  result.method = method;

  if (method == MannWhitneyMethod::kExact) {
    if (result.ties) fail("mann_whitney_u", "the exact method needs samples without ties");
    if (!exact_fits) {
      fail("mann_whitney_u", "the exact method is limited to C(n1 + n2, n1) < 9e18 (n1 = " +
                                 std::to_string(n1) + ", n2 = " + std::to_string(n2) + ")");
    }
    const std::vector<std::uint64_t> counts = mwu_null_counts(std::min(n1, n2), std::max(n1, n2));
    // The null distribution is symmetric: P(U >= k) = P(U <= mn - k) (as scipy's _MWU.sf).
    const auto k = static_cast<std::size_t>(std::llround(u_max));
    const std::size_t mn = n1 * n2;
    std::uint64_t tail = 0;
    std::uint64_t total = 0;
    for (std::size_t u = 0; u <= mn; ++u) {
      total += counts[u];
      if (u <= mn - k) tail += counts[u];
    }
    result.p = std::min(1.0, 2.0 * static_cast<double>(tail) / static_cast<double>(total));
    result.z = 0.0;
    return result;
  }

  // Asymptotic: z = (U - n1 n2 / 2 - 1/2) / sigma with the tie-corrected
  // sigma^2 = n1 n2 / 12 ((n + 1) - sum (t^3 - t) / (n (n - 1)))   (scipy's _get_mwu_z).
  const double n = n1d + n2d;
  const double variance =
      n1d * n2d / 12.0 * ((n + 1.0) - tie_term(ranking.tie_sizes) / (n * (n - 1.0)));
  if (!(variance > 0.0)) {  // every pooled value identical: no evidence either way
    result.z = 0.0;
    result.p = 1.0;
    return result;
  }
  result.z = (u_max - n1d * n2d / 2.0 - 0.5) / std::sqrt(variance);
  const boost::math::normal_distribution<double> standard_normal(0.0, 1.0);
  const double sf = boost::math::cdf(boost::math::complement(standard_normal, result.z));
  result.p = std::clamp(2.0 * sf, 0.0, 1.0);
  return result;
}

// -------------------------------------------------------------------------------------------
// Holm-Bonferroni
// -------------------------------------------------------------------------------------------

std::vector<double> holm(const std::vector<double>& p) {
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (std::isnan(p[i])) fail("holm", "p-value at index " + std::to_string(i) + " is NaN");
    if (p[i] < 0.0 || p[i] > 1.0) {
      fail("holm",
           "p-value at index " + std::to_string(i) + " is outside [0, 1]: " + std::to_string(p[i]));
    }
  }
  const std::size_t m = p.size();
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&p](std::size_t i, std::size_t j) { return p[i] < p[j]; });
  std::vector<double> adjusted(m);
  double running_max = 0.0;
  for (std::size_t rank = 0; rank < m; ++rank) {
    const double scaled = static_cast<double>(m - rank) * p[order[rank]];  // (m - j + 1) p_(j)
    running_max = std::max(running_max, std::min(1.0, scaled));
    adjusted[order[rank]] = running_max;
  }
  return adjusted;
}

// -------------------------------------------------------------------------------------------
// Vargha-Delaney A12
// -------------------------------------------------------------------------------------------

double a12(const std::vector<double>& a, const std::vector<double>& b) {
  check_sample("a12", a, "sample a");
  check_sample("a12", b, "sample b");
  // Count pairs directly (Vargha & Delaney 2000, Eq. 14); O(n1 n2) is nothing at n = 31.
  double wins = 0.0;
  for (double x : a) {
    for (double y : b) {
      if (x > y) {
        wins += 1.0;
      } else if (x == y) {
        wins += 0.5;
      }
    }
  }
  return wins / (static_cast<double>(a.size()) * static_cast<double>(b.size()));
}

A12Magnitude a12_magnitude(double a12_value) {
  if (!(a12_value >= 0.0 && a12_value <= 1.0)) {
    fail("a12_magnitude", "A12 must be in [0, 1], got " + std::to_string(a12_value));
  }
  // Thresholds 0.56 / 0.64 / 0.71 (Vargha & Delaney 2000, p. 106), mirrored below 0.5. The
  // tolerance makes 0.44 and 0.56 fall on the same side despite their binary representation.
  constexpr double kTol = 1e-12;
  const double d = std::abs(a12_value - 0.5);
  if (d < 0.06 - kTol) return A12Magnitude::kNegligible;
  if (d < 0.14 - kTol) return A12Magnitude::kSmall;
  if (d < 0.21 - kTol) return A12Magnitude::kMedium;
  return A12Magnitude::kLarge;
}

// -------------------------------------------------------------------------------------------
// aRT
// -------------------------------------------------------------------------------------------

RunningTime expected_running_time(const std::vector<RunOutcome>& runs) {
  if (runs.empty()) fail("expected_running_time", "no runs");
  RunningTime rt;
  rt.runs = runs.size();
  double total = 0.0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const double e = runs[i].evaluations;
    if (!std::isfinite(e) || e < 0.0) {
      fail("expected_running_time", "evaluations of run " + std::to_string(i) +
                                        " must be finite and >= 0, got " + std::to_string(e));
    }
    total += e;
    if (runs[i].reached) ++rt.successes;
  }
  rt.success_rate = static_cast<double>(rt.successes) / static_cast<double>(rt.runs);
  rt.art = rt.successes > 0 ? total / static_cast<double>(rt.successes) : kInf;
  return rt;
}

// -------------------------------------------------------------------------------------------
// Friedman
// -------------------------------------------------------------------------------------------

FriedmanResult friedman(const std::vector<std::vector<double>>& table) {
  if (table.empty()) fail("friedman", "the table has no blocks");
  const std::size_t k = table.front().size();
  if (k == 0) fail("friedman", "block 0 has no treatments");
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (table[i].size() != k) {
      fail("friedman", "block " + std::to_string(i) + " has " + std::to_string(table[i].size()) +
                           " values, block 0 has " + std::to_string(k));
    }
    for (std::size_t j = 0; j < k; ++j) {
      if (std::isnan(table[i][j])) {
        fail("friedman", "NaN at block " + std::to_string(i) + ", treatment " + std::to_string(j));
      }
    }
  }
  FriedmanResult result;
  result.blocks = table.size();
  result.treatments = k;
  const double n = static_cast<double>(table.size());
  const double kd = static_cast<double>(k);

  std::vector<double> rank_sums(k, 0.0);
  double ties = 0.0;
  for (const auto& block : table) {
    const Ranking r = average_ranks(block);
    for (std::size_t j = 0; j < k; ++j) rank_sums[j] += r.ranks[j];
    ties += tie_term(r.tie_sizes);
  }
  result.mean_ranks.resize(k);
  for (std::size_t j = 0; j < k; ++j) result.mean_ranks[j] = rank_sums[j] / n;

  result.statistic = kNaN;
  result.p = kNaN;
  if (k < 2) {
    result.note = "fewer than 2 treatments";
    return result;
  }
  if (table.size() < 2) {
    result.note = "fewer than 2 blocks";
    return result;
  }
  const double correction = 1.0 - ties / (kd * (kd * kd - 1.0) * n);
  if (!(correction > 0.0)) {
    result.note = "every block is fully tied";
    return result;
  }
  double ssbn = 0.0;
  for (double s : rank_sums) ssbn += s * s;
  const double chi2 = (12.0 / (kd * n * (kd + 1.0)) * ssbn - 3.0 * n * (kd + 1.0)) / correction;
  result.statistic = std::max(0.0, chi2);  // guard a -1e-15 from rounding
  const boost::math::chi_squared_distribution<double> dist(kd - 1.0);
  result.p = boost::math::cdf(boost::math::complement(dist, result.statistic));
  return result;
}

// -------------------------------------------------------------------------------------------
// Bootstrap
// -------------------------------------------------------------------------------------------

ConfidenceInterval bootstrap_median_ci(const std::vector<double>& x, double level,
                                       std::size_t resamples, std::uint64_t seed) {
  check_sample("bootstrap_median_ci", x);
  if (!(level > 0.0 && level < 1.0)) {
    fail("bootstrap_median_ci", "level must be in (0, 1), got " + std::to_string(level));
  }
  if (resamples < 1) fail("bootstrap_median_ci", "resamples must be >= 1");

  ConfidenceInterval ci;
  ci.level = level;
  ci.estimate = median(x);

  const std::size_t n = x.size();
  std::mt19937_64 engine(seed);  // the standard fixes its output sequence
  std::vector<double> resample(n);
  std::vector<double> medians(resamples);
  for (std::size_t r = 0; r < resamples; ++r) {
    for (std::size_t i = 0; i < n; ++i) resample[i] = x[uniform_index(engine, n)];
    // Type-7 median: the middle order statistic, or the mean of the two middle ones.
    const std::size_t mid = n / 2;
    std::nth_element(resample.begin(), resample.begin() + mid, resample.end());
    double med = resample[mid];
    if (n % 2 == 0) {
      const double lower = *std::max_element(resample.begin(), resample.begin() + mid);
      med = lerp(lower, med, 0.5);
    }
    medians[r] = med;
  }
  std::sort(medians.begin(), medians.end());
  ci.lo = sorted_quantile(medians, (1.0 - level) / 2.0);
  ci.hi = sorted_quantile(medians, (1.0 + level) / 2.0);
  return ci;
}

}  // namespace insid::stats
