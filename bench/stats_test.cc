#include "bench/stats.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_support/enum_tables.h"

namespace insid::stats {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Expects `call` to throw std::invalid_argument whose message contains `part`.
template <class F>
void ExpectInvalid(F call, const std::string& part) {
  try {
    call();
    ADD_FAILURE() << "no exception, expected one mentioning \"" << part << "\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Descriptives
// ---------------------------------------------------------------------------------------------

// numpy.quantile(x, q) (numpy 1.24, default method='linear'):
//   x = [3.1, -1.0, 7.25, 0.5, 2.0, 10.0, 4.4]
TEST(Quantile, MatchesNumpyLinear) {
  const std::vector<double> x = {3.1, -1.0, 7.25, 0.5, 2.0, 10.0, 4.4};
  EXPECT_DOUBLE_EQ(quantile(x, 0.0), -1.0);
  EXPECT_DOUBLE_EQ(quantile(x, 0.1), -0.09999999999999987);
  EXPECT_DOUBLE_EQ(quantile(x, 0.25), 1.25);
  EXPECT_DOUBLE_EQ(quantile(x, 0.5), 3.1);
  EXPECT_DOUBLE_EQ(quantile(x, 0.75), 5.825);
  EXPECT_DOUBLE_EQ(quantile(x, 0.9), 8.350000000000001);
  EXPECT_DOUBLE_EQ(quantile(x, 1.0), 10.0);
  EXPECT_DOUBLE_EQ(median(x), 3.1);
}

// Even n: np.quantile([5, 1, 2, 8], [0.25, 0.5, 0.75]) = [1.75, 3.5, 5.75].
TEST(Quantile, EvenSampleQuartiles) {
  const std::vector<double> x = {5.0, 1.0, 2.0, 8.0};
  const Quartiles q = quartiles(x);
  EXPECT_DOUBLE_EQ(q.q1, 1.75);
  EXPECT_DOUBLE_EQ(q.median, 3.5);
  EXPECT_DOUBLE_EQ(q.q3, 5.75);
  EXPECT_DOUBLE_EQ(q.iqr(), 4.0);
  EXPECT_DOUBLE_EQ(iqr(x), 4.0);
  EXPECT_DOUBLE_EQ(median(x), 3.5);
  EXPECT_DOUBLE_EQ(median({42.0}), 42.0);
}

TEST(Quantile, RejectsBadInput) {
  ExpectInvalid([] { median({}); }, "empty");
  ExpectInvalid([] { quantile({1.0, kNaN, 2.0}, 0.5); }, "NaN at index 1");
  ExpectInvalid([] { quantile({1.0, 2.0}, 1.5); }, "q must be in [0, 1]");
  ExpectInvalid([] { quartiles({}); }, "quartiles");
  ExpectInvalid([] { iqr({kNaN}); }, "NaN");
}

// ---------------------------------------------------------------------------------------------
// Mann-Whitney U
// ---------------------------------------------------------------------------------------------

// Ties -> asymptotic. scipy 1.10:
//   mannwhitneyu(a, b, alternative='two-sided', use_continuity=True, method='auto')
//   -> statistic=12.5, pvalue=0.02577194350445826
TEST(MannWhitney, TiesUseTheAsymptoticMethodAsScipy) {
  const std::vector<double> a = {1.2, 3.4, 3.4, 5.0, 7.1, 2.2, 9.0, 3.4};
  const std::vector<double> b = {3.4, 6.0, 8.1, 9.0, 10.5, 7.1, 12.0, 4.4, 11.0};
  const MannWhitneyResult r = mann_whitney_u(a, b);
  EXPECT_EQ(r.method, MannWhitneyMethod::kAsymptotic);
  EXPECT_TRUE(r.ties);
  EXPECT_DOUBLE_EQ(r.u, 12.5);
  EXPECT_NEAR(r.p, 0.02577194350445826, 1e-12);
  EXPECT_TRUE(std::isfinite(r.z));
  // Swapping the samples gives U_b = n1 n2 - U_a and the same two-sided p.
  const MannWhitneyResult s = mann_whitney_u(b, a);
  EXPECT_DOUBLE_EQ(s.u, 8.0 * 9.0 - 12.5);
  EXPECT_NEAR(s.p, r.p, 1e-15);
  EXPECT_THROW(mann_whitney_u(a, b, MannWhitneyMethod::kExact), std::invalid_argument);
}

// Small, no ties -> exact. Hand: a's ranks in the pooled 11 values are 1, 2, 3, 5, 6
// -> R_a = 17, U_a = 17 - 15 = 2; P(U <= 2) = (1 + 1 + 2) / C(11, 5) = 4 / 462, p = 8 / 462.
// scipy: mannwhitneyu(a, b, method='auto') -> (2.0, 0.017316017316017316);
//        method='asymptotic' -> (2.0, 0.022478873366125265).
TEST(MannWhitney, SmallSampleWithoutTiesIsExact) {
  const std::vector<double> a = {0.8, 1.9, 2.7, 4.1, 5.5};
  const std::vector<double> b = {3.0, 6.2, 7.4, 8.8, 9.1, 10.3};
  const MannWhitneyResult r = mann_whitney_u(a, b);
  EXPECT_EQ(r.method, MannWhitneyMethod::kExact);
  EXPECT_FALSE(r.ties);
  EXPECT_DOUBLE_EQ(r.u, 2.0);
  EXPECT_NEAR(r.p, 8.0 / 462.0, 1e-15);
  EXPECT_NEAR(r.p, 0.017316017316017316, 1e-15);
  const MannWhitneyResult asym = mann_whitney_u(a, b, MannWhitneyMethod::kAsymptotic);
  EXPECT_EQ(asym.method, MannWhitneyMethod::kAsymptotic);
  EXPECT_NEAR(asym.p, 0.022478873366125265, 1e-12);
}

// Complete separation: U = 0, p = 2 / C(11, 3) = 2 / 165.
// scipy: mannwhitneyu([1..8], [9, 10, 11], method='exact') -> (0.0, 0.012121212121212121)
TEST(MannWhitney, CompleteSeparationExact) {
  const MannWhitneyResult r =
      mann_whitney_u({1, 2, 3, 4, 5, 6, 7, 8}, {9, 10, 11}, MannWhitneyMethod::kExact);
  EXPECT_DOUBLE_EQ(r.u, 0.0);
  EXPECT_NEAR(r.p, 2.0 / 165.0, 1e-15);
}

// Larger exact cases (forced) against scipy 1.10, method='exact' and 'asymptotic':
//   a (12) and b (15) from np.round(default_rng(3).normal(...), 6):
//     exact -> (36.0, 0.007404224378245108), asymptotic -> (36.0, 0.009040133006019455)
//   20 x 20 (values 1..40, a = those not divisible by 3, first 20):
//     exact -> (90.0, 0.002393533495724335), auto (asymptotic) -> 0.003056629228174791
TEST(MannWhitney, LargerExactAndAutoMatchScipy) {
  const std::vector<double> a = {2.040919,  -2.555665, 0.418099,  -0.56777, -0.452649, -0.215597,
                                 -2.019986, -0.231932, -0.865213, 3.323,    0.225787,  -0.352631};
  const std::vector<double> b = {0.518713, 0.131954, -0.255151, 0.409199, 1.281945,
                                 0.561446, 1.757759, 0.600198,  0.82426,  2.345821,
                                 1.345106, 0.294771, 0.617161,  1.340525, 2.735088};
  const MannWhitneyResult exact = mann_whitney_u(a, b, MannWhitneyMethod::kExact);
  EXPECT_DOUBLE_EQ(exact.u, 36.0);
  EXPECT_NEAR(exact.p, 0.007404224378245108, 1e-14);
  const MannWhitneyResult automatic = mann_whitney_u(a, b);  // both n > 8 -> asymptotic
  EXPECT_EQ(automatic.method, MannWhitneyMethod::kAsymptotic);
  EXPECT_NEAR(automatic.p, 0.009040133006019455, 1e-12);

  std::vector<double> c;
  std::vector<double> d;
  for (int v = 1; v <= 40; ++v) {
    if (v % 3 != 0 && c.size() < 20) {
      c.push_back(v);
    } else {
      d.push_back(v);
    }
  }
  ASSERT_EQ(c.size(), 20u);
  ASSERT_EQ(d.size(), 20u);
  const MannWhitneyResult e20 = mann_whitney_u(c, d, MannWhitneyMethod::kExact);
  EXPECT_DOUBLE_EQ(e20.u, 90.0);
  EXPECT_NEAR(e20.p, 0.002393533495724335, 1e-14);
  EXPECT_NEAR(mann_whitney_u(c, d).p, 0.003056629228174791, 1e-12);
}

// The exact null distribution sums to one and is symmetric: identical samples shifted so
// that U = n1 n2 / 2 give p = 1 (clipped), and p never exceeds 1.
TEST(MannWhitney, ExactPIsOneAtTheCentre) {
  const MannWhitneyResult r = mann_whitney_u({1, 4, 5, 8}, {2, 3, 6, 7}, MannWhitneyMethod::kExact);
  EXPECT_DOUBLE_EQ(r.u, 8.0);
  EXPECT_DOUBLE_EQ(r.p, 1.0);
}

// All values equal: zero variance; scipy returns (0.5, 1.0) for mannwhitneyu([5], [5]).
TEST(MannWhitney, AllTiedGivesPOne) {
  const MannWhitneyResult r = mann_whitney_u({5.0, 5.0}, {5.0, 5.0, 5.0});
  EXPECT_EQ(r.method, MannWhitneyMethod::kAsymptotic);
  EXPECT_DOUBLE_EQ(r.u, 3.0);
  EXPECT_DOUBLE_EQ(r.p, 1.0);
}

// Exact counts would overflow 64 bits: auto falls back, explicit exact refuses.
TEST(MannWhitney, ExactTooLargeFallsBackOrThrows) {
  std::vector<double> a(40);
  std::vector<double> b(40);
  for (int i = 0; i < 40; ++i) {
    a[i] = 2 * i;
    b[i] = 2 * i + 1;
  }
  EXPECT_EQ(mann_whitney_u(a, b).method, MannWhitneyMethod::kAsymptotic);
  ExpectInvalid([&] { mann_whitney_u(a, b, MannWhitneyMethod::kExact); }, "limited");
}

TEST(MannWhitney, RejectsBadInput) {
  ExpectInvalid([] { mann_whitney_u({}, {1.0}); }, "sample a is empty");
  ExpectInvalid([] { mann_whitney_u({1.0}, {2.0, kNaN}); }, "sample b contains NaN at index 1");
  EXPECT_EQ(to_string(MannWhitneyMethod::kExact), "exact");
  EXPECT_EQ(to_string(MannWhitneyMethod::kAsymptotic), "asymptotic");
}

// ---------------------------------------------------------------------------------------------
// Holm
// ---------------------------------------------------------------------------------------------

// Hand: sorted p = 0.005, 0.01, 0.03, 0.04, 0.5 times 5, 4, 3, 2, 1
//   = 0.025, 0.04, 0.09, 0.08, 0.5; running max -> 0.025, 0.04, 0.09, 0.09, 0.5.
TEST(Holm, KnownVector) {
  const std::vector<double> adj = holm({0.01, 0.04, 0.03, 0.005, 0.5});
  ASSERT_EQ(adj.size(), 5u);
  EXPECT_DOUBLE_EQ(adj[0], 0.04);
  EXPECT_DOUBLE_EQ(adj[1], 0.09);
  EXPECT_DOUBLE_EQ(adj[2], 0.09);
  EXPECT_DOUBLE_EQ(adj[3], 0.025);
  EXPECT_DOUBLE_EQ(adj[4], 0.5);
}

// Hand: [0.3, 0.4, 0.2] -> 0.6, 0.6 (monotone), 0.6; [0.6, 0.7] -> capped at 1.
TEST(Holm, MonotoneAndCapped) {
  const std::vector<double> adj = holm({0.3, 0.4, 0.2});
  EXPECT_DOUBLE_EQ(adj[0], 0.6);
  EXPECT_DOUBLE_EQ(adj[1], 0.6);
  EXPECT_DOUBLE_EQ(adj[2], 0.6);
  const std::vector<double> capped = holm({0.6, 0.7});
  EXPECT_DOUBLE_EQ(capped[0], 1.0);
  EXPECT_DOUBLE_EQ(capped[1], 1.0);
  EXPECT_TRUE(holm({}).empty());
  EXPECT_DOUBLE_EQ(holm({0.2})[0], 0.2);
}

TEST(Holm, RejectsBadInput) {
  ExpectInvalid([] { holm({0.1, kNaN}); }, "index 1 is NaN");
  ExpectInvalid([] { holm({1.2}); }, "outside [0, 1]");
  ExpectInvalid([] { holm({-0.1}); }, "outside [0, 1]");
}

// ---------------------------------------------------------------------------------------------
// A12
// ---------------------------------------------------------------------------------------------

// Hand: a = {1, 2, 3}, b = {2, 4}: pairs a > b: (3, 2) = 1; ties: (2, 2) = 0.5 -> 1.5 / 6.
TEST(A12, SmallSamplesByHand) {
  EXPECT_DOUBLE_EQ(a12({1, 2, 3}, {2, 4}), 0.25);
  EXPECT_DOUBLE_EQ(a12({2, 4}, {1, 2, 3}), 0.75);  // complement
  EXPECT_DOUBLE_EQ(a12({1, 2, 3, 4}, {1, 2, 3, 4}), 0.5);
  EXPECT_DOUBLE_EQ(a12({10, 11}, {1, 2, 3}), 1.0);
  // A12 = U_a / (n_a n_b), with the U of the tied scipy case above (12.5 / 72).
  EXPECT_DOUBLE_EQ(a12({1.2, 3.4, 3.4, 5.0, 7.1, 2.2, 9.0, 3.4},
                       {3.4, 6.0, 8.1, 9.0, 10.5, 7.1, 12.0, 4.4, 11.0}),
                   12.5 / 72.0);
  EXPECT_DOUBLE_EQ(a12({-kInf, 1.0}, {0.0, kInf}), 0.25);  // infinities rank like values
}

TEST(A12, MagnitudeThresholdsAreSymmetric) {
  EXPECT_EQ(a12_magnitude(0.5), A12Magnitude::kNegligible);
  EXPECT_EQ(a12_magnitude(0.555), A12Magnitude::kNegligible);
  EXPECT_EQ(a12_magnitude(0.445), A12Magnitude::kNegligible);
  EXPECT_EQ(a12_magnitude(0.56), A12Magnitude::kSmall);
  EXPECT_EQ(a12_magnitude(0.44), A12Magnitude::kSmall);
  EXPECT_EQ(a12_magnitude(0.639), A12Magnitude::kSmall);
  EXPECT_EQ(a12_magnitude(0.64), A12Magnitude::kMedium);
  EXPECT_EQ(a12_magnitude(0.36), A12Magnitude::kMedium);
  EXPECT_EQ(a12_magnitude(0.709), A12Magnitude::kMedium);
  EXPECT_EQ(a12_magnitude(0.71), A12Magnitude::kLarge);
  EXPECT_EQ(a12_magnitude(0.29), A12Magnitude::kLarge);
  EXPECT_EQ(a12_magnitude(0.0), A12Magnitude::kLarge);
  EXPECT_EQ(a12_magnitude(1.0), A12Magnitude::kLarge);
  EXPECT_EQ(to_string(A12Magnitude::kMedium), "medium");
  EXPECT_EQ(to_string(a12_magnitude(0.25)), "large");
}

TEST(A12, RejectsBadInput) {
  ExpectInvalid([] { a12({}, {1.0}); }, "sample a is empty");
  ExpectInvalid([] { a12({1.0}, {kNaN}); }, "sample b contains NaN");
  ExpectInvalid([] { a12_magnitude(1.5); }, "[0, 1]");
  ExpectInvalid([] { a12_magnitude(kNaN); }, "[0, 1]");
}

// ---------------------------------------------------------------------------------------------
// aRT
// ---------------------------------------------------------------------------------------------

// Hand: evaluations 100 (hit), 250 (miss), 150 (hit), 300 (miss): aRT = 800 / 2 = 400.
TEST(ExpectedRunningTime, ByHand) {
  const RunningTime rt =
      expected_running_time({{100, true}, {250, false}, {150, true}, {300, false}});
  EXPECT_DOUBLE_EQ(rt.art, 400.0);
  EXPECT_DOUBLE_EQ(rt.success_rate, 0.5);
  EXPECT_EQ(rt.successes, 2u);
  EXPECT_EQ(rt.runs, 4u);
  // All successful: aRT is the mean.
  EXPECT_DOUBLE_EQ(expected_running_time({{10, true}, {20, true}, {60, true}}).art, 30.0);
}

TEST(ExpectedRunningTime, NoSuccessIsInfinite) {
  const RunningTime rt = expected_running_time({{500, false}, {500, false}});
  EXPECT_TRUE(std::isinf(rt.art));
  EXPECT_GT(rt.art, 0.0);
  EXPECT_DOUBLE_EQ(rt.success_rate, 0.0);
}

TEST(ExpectedRunningTime, RejectsBadInput) {
  ExpectInvalid([] { expected_running_time({}); }, "no runs");
  ExpectInvalid([] { expected_running_time({{1, true}, {kNaN, true}}); }, "run 1");
  ExpectInvalid([] { expected_running_time({{-1, false}}); }, ">= 0");
}

// ---------------------------------------------------------------------------------------------
// Friedman
// ---------------------------------------------------------------------------------------------

// scipy.stats.friedmanchisquare(*table.T) with ties in block 3:
//   table = [[1, 2, 3, 4], [2, 1, 3.5, 3.9], [0.5, 0.7, 0.6, 2], [1, 1, 2, 3], [4, 3, 2, 1]]
//   -> statistic=4.102040816326527, pvalue=0.25065428964587494
TEST(Friedman, MatchesScipyWithTies) {
  const FriedmanResult r = friedman({{1.0, 2.0, 3.0, 4.0},
                                     {2.0, 1.0, 3.5, 3.9},
                                     {0.5, 0.7, 0.6, 2.0},
                                     {1.0, 1.0, 2.0, 3.0},
                                     {4.0, 3.0, 2.0, 1.0}});
  EXPECT_NEAR(r.statistic, 4.102040816326527, 1e-12);
  EXPECT_NEAR(r.p, 0.25065428964587494, 1e-12);
  EXPECT_EQ(r.blocks, 5u);
  EXPECT_EQ(r.treatments, 4u);
  EXPECT_TRUE(r.note.empty());
  // Hand: rank sums 1+2+1+1.5+4 = 9.5, 2+1+3+1.5+3 = 10.5, 3+3+2+3+2 = 13, 4+4+4+4+1 = 17.
  ASSERT_EQ(r.mean_ranks.size(), 4u);
  EXPECT_DOUBLE_EQ(r.mean_ranks[0], 9.5 / 5);
  EXPECT_DOUBLE_EQ(r.mean_ranks[1], 10.5 / 5);
  EXPECT_DOUBLE_EQ(r.mean_ranks[2], 13.0 / 5);
  EXPECT_DOUBLE_EQ(r.mean_ranks[3], 17.0 / 5);
}

// scipy: friedmanchisquare([1,2,1,1], [2,3,3,2], [3,1,2,3]) -> (3.5, 0.1737739434504451)
TEST(Friedman, MatchesScipyThreeTreatments) {
  const FriedmanResult r = friedman({{1, 2, 3}, {2, 3, 1}, {1, 3, 2}, {1, 2, 3}});
  EXPECT_NEAR(r.statistic, 3.5, 1e-12);
  EXPECT_NEAR(r.p, 0.1737739434504451, 1e-12);
}

// k = 2 (scipy refuses it): the statistic reduces to the sign test's (wins - losses)^2 / n =
// (2 - 1)^2 / 3 by hand; p = scipy.stats.chi2.sf(1/3, 1) = 0.5637028616507731.
TEST(Friedman, TwoTreatmentsByHand) {
  const FriedmanResult r = friedman({{1, 2}, {1, 2}, {2, 1}});
  EXPECT_NEAR(r.statistic, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(r.p, 0.5637028616507731, 1e-12);
}

TEST(Friedman, DegenerateTablesGiveNaNWithANote) {
  const FriedmanResult one_block = friedman({{3.0, 1.0, 2.0}});
  EXPECT_TRUE(std::isnan(one_block.p));
  EXPECT_NE(one_block.note.find("blocks"), std::string::npos);
  EXPECT_DOUBLE_EQ(one_block.mean_ranks[1], 1.0);  // ranks still reported
  const FriedmanResult one_treatment = friedman({{1.0}, {2.0}});
  EXPECT_TRUE(std::isnan(one_treatment.p));
  EXPECT_NE(one_treatment.note.find("treatments"), std::string::npos);
  const FriedmanResult tied = friedman({{1.0, 1.0}, {2.0, 2.0}});
  EXPECT_TRUE(std::isnan(tied.p));
  EXPECT_NE(tied.note.find("tied"), std::string::npos);
}

TEST(Friedman, RejectsBadInput) {
  ExpectInvalid([] { friedman({}); }, "no blocks");
  ExpectInvalid([] { friedman({{1.0, 2.0}, {1.0}}); }, "block 1 has 1 values");
  ExpectInvalid([] { friedman({{1.0, 2.0}, {kNaN, 1.0}}); }, "NaN at block 1, treatment 0");
}

// ---------------------------------------------------------------------------------------------
// Bootstrap
// ---------------------------------------------------------------------------------------------

// The C++ standard fixes mt19937_64's 10000th output of the default seed ([rand.predef]); the
// portability of bootstrap_median_ci rests on it and on uniform_index.
TEST(Bootstrap, EngineIsTheStandardOne) {
  std::mt19937_64 engine;
  engine.discard(9999);
  EXPECT_EQ(engine(), 9981545732273789042ull);
}

// uniform_index with a scripted source: words at or above the rejection limit are skipped.
TEST(Bootstrap, UniformIndexRejectsTheBiasedTail) {
  struct Scripted {
    std::vector<std::uint64_t> words;
    std::size_t next = 0;
    std::uint64_t operator()() { return words[next++]; }
  };
  // n = 3: 2^64 mod 3 = 1, so the largest word UINT64_MAX is rejected.
  Scripted s{{UINT64_MAX, 7}};
  EXPECT_EQ(uniform_index(s, 3), 1u);
  EXPECT_EQ(s.next, 2u);
  Scripted t{{UINT64_MAX}};
  EXPECT_EQ(uniform_index(t, 1), 0u);  // n = 1 accepts every word
}

TEST(Bootstrap, DeterministicAndBracketsTheMedian) {
  const std::vector<double> x = {3.2, 1.1, 4.7, 2.2, 9.8, 5.5, 0.3, 7.7, 6.1, 2.9, 4.4};
  const ConfidenceInterval a = bootstrap_median_ci(x, 0.95, 2000, 17);
  const ConfidenceInterval b = bootstrap_median_ci(x, 0.95, 2000, 17);
  EXPECT_EQ(a.lo, b.lo);
  EXPECT_EQ(a.hi, b.hi);
  EXPECT_DOUBLE_EQ(a.estimate, 4.4);
  EXPECT_DOUBLE_EQ(a.level, 0.95);
  EXPECT_LE(a.lo, a.estimate);
  EXPECT_GE(a.hi, a.estimate);
  EXPECT_LT(a.lo, a.hi);
  // Resampled medians of 11 values are order statistics of x: the bounds must be data values.
  EXPECT_NE(std::find(x.begin(), x.end(), a.lo), x.end());
  EXPECT_NE(std::find(x.begin(), x.end(), a.hi), x.end());
  // A narrower level gives a nested interval.
  const ConfidenceInterval c = bootstrap_median_ci(x, 0.5, 2000, 17);
  EXPECT_GE(c.lo, a.lo);
  EXPECT_LE(c.hi, a.hi);
  // Pinned (values from this implementation; they must not change across platforms or
  // compilers, which is what the portable sampling is for).
  EXPECT_DOUBLE_EQ(a.lo, 2.2);
  EXPECT_DOUBLE_EQ(a.hi, 6.1);
  std::vector<double> y(20);
  for (int i = 0; i < 20; ++i) y[i] = i + 1;
  const ConfidenceInterval e = bootstrap_median_ci(y, 0.9, 500, 42);
  EXPECT_DOUBLE_EQ(e.lo, 7.0);
  EXPECT_DOUBLE_EQ(e.hi, 13.5);
  // A constant sample has a zero-width interval.
  const ConfidenceInterval d = bootstrap_median_ci({2.5, 2.5, 2.5}, 0.95, 100, 1);
  EXPECT_DOUBLE_EQ(d.lo, 2.5);
  EXPECT_DOUBLE_EQ(d.hi, 2.5);
}

// Coverage: over 300 normal samples of n = 31, the 95 % interval should contain the true
// median 0 in roughly 95 % of them (percentile bootstrap of the median is a little
// conservative/liberal with discrete order statistics; accept 88 % .. 99.5 %).
TEST(Bootstrap, CoverageIsNearTheNominalLevel) {
  std::mt19937_64 gen(2024);
  std::normal_distribution<double> normal(0.0, 1.0);  // only the data, not the CI, uses it
  int covered = 0;
  const int trials = 300;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> x(31);
    for (double& v : x) v = normal(gen);
    const ConfidenceInterval ci = bootstrap_median_ci(x, 0.95, 1000, 100 + t);
    if (ci.lo <= 0.0 && 0.0 <= ci.hi) ++covered;
  }
  const double coverage = static_cast<double>(covered) / trials;
  EXPECT_GT(coverage, 0.88);
  EXPECT_LT(coverage, 0.995);
}

TEST(Bootstrap, RejectsBadInput) {
  ExpectInvalid([] { bootstrap_median_ci({}); }, "empty");
  ExpectInvalid([] { bootstrap_median_ci({1.0, kNaN}); }, "NaN at index 1");
  ExpectInvalid([] { bootstrap_median_ci({1.0}, 1.0); }, "level");
  ExpectInvalid([] { bootstrap_median_ci({1.0}, 0.95, 0); }, "resamples");
}

// The names written to summary.json.
TEST(StatsNames, MethodAndMagnitudeTablesRoundTrip) {
  test::expect_enum_table(kMannWhitneyMethodNames,
                          {{MannWhitneyMethod::kAuto, "auto"},
                           {MannWhitneyMethod::kExact, "exact"},
                           {MannWhitneyMethod::kAsymptotic, "asymptotic"}});
  test::expect_enum_table(kA12MagnitudeNames, {{A12Magnitude::kNegligible, "negligible"},
                                               {A12Magnitude::kSmall, "small"},
                                               {A12Magnitude::kMedium, "medium"},
                                               {A12Magnitude::kLarge, "large"}});
  EXPECT_EQ(to_string(MannWhitneyMethod::kAsymptotic), "asymptotic");
  EXPECT_EQ(to_string(A12Magnitude::kMedium), "medium");
}

}  // namespace
}  // namespace insid::stats
