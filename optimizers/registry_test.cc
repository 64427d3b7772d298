// The algorithm table: every name round-trips, the families and the listing order, the unknown
// name's message, registration's refusals, and traits that match what the optimizers do
// (the interfaces they implement, whether the seed changes the run).
#include "optimizers/registry.h"

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "optimizers/test_functions.h"
#include "test_support/enum_tables.h"
#include "test_support/optimizer_runs.h"

namespace insid::opt {
namespace {

using Family = AlgorithmTraits::Family;

// The shifted sphere in residual form, so that every algorithm (least-squares ones included)
// runs on it.
class ResidualSphere final : public Problem, public ResidualProblem {
 public:
  explicit ResidualSphere(int n) : Problem(Bounds::unit_box(n)), o_(benchmark_optimum(n)) {}
  int residual_count() const override { return dimension(); }
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    for (std::size_t i = 0; i < xs.size(); ++i) f[i] = (xs[i] - o_).squaredNorm();
  }
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r,
                               std::span<double> f) const override {
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const Eigen::VectorXd d = xs[i] - o_;
      r[i].assign(d.data(), d.data() + d.size());
      f[i] = d.squaredNorm();
    }
  }

 private:
  Eigen::VectorXd o_;
};

std::string unknown_message(std::string_view name) {
  try {
    (void)algorithm_traits(name);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(Registry, EveryListedNameRoundTripsThroughTheTable) {
  const std::vector<std::string> names = algorithm_names();
  ASSERT_GE(names.size(), 10u);
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const AlgorithmEntry entry = algorithm_entry(name);
    EXPECT_EQ(entry.name, name);
    EXPECT_FALSE(entry.traits.description.empty());
    EXPECT_EQ(std::count(names.begin(), names.end(), name), 1);
  }
}

TEST(Registry, FamiliesGiveThePaperAndBaselineListsInTableOrder) {
  EXPECT_EQ(paper_algorithm_names(), (std::vector<std::string>{"ga", "pso", "pio", "dvpio"}));
  EXPECT_EQ(baseline_algorithm_names(),
            (std::vector<std::string>{"cmaes", "de", "compass", "lm", "bobyqa", "neldermead"}));
  for (const std::string& name : paper_algorithm_names())
    EXPECT_EQ(algorithm_traits(name).family, Family::kPaper) << name;
  for (const std::string& name : baseline_algorithm_names())
    EXPECT_EQ(algorithm_traits(name).family, Family::kBaseline) << name;
  // The listing starts with the paper's four, then the baselines (registered ones follow).
  const std::vector<std::string> names = algorithm_names();
  const std::vector<std::string> first(names.begin(), names.begin() + 10);
  std::vector<std::string> expected = paper_algorithm_names();
  for (const std::string& name : baseline_algorithm_names()) expected.push_back(name);
  EXPECT_EQ(first, expected);
}

TEST(Registry, ExternalIsAPrefixEntryNotListed) {
  const AlgorithmEntry entry = algorithm_entry("external:/bin/true");
  EXPECT_EQ(entry.name, "external:");
  EXPECT_EQ(entry.traits.family, Family::kExternal);
  EXPECT_EQ(default_parameters("external:anything"), (ParameterList{{"timeout_s", 60.0}}));
  const std::vector<std::string> names = algorithm_names();
  EXPECT_EQ(std::count_if(names.begin(), names.end(),
                          [](const std::string& n) { return n.find(':') != std::string::npos; }),
            0);
  // The bare prefix word is no algorithm.
  EXPECT_NE(unknown_message("external"), "");
}

TEST(Registry, UnknownNameIsAnInvalidArgumentListingTheValidNames) {
  std::string list;
  for (const std::string& name : algorithm_names()) list += (list.empty() ? "" : ", ") + name;
  EXPECT_EQ(unknown_message("annealing"),
            "unknown optimizer 'annealing'; valid optimizers: " + list);
  EXPECT_THROW((void)algorithm_entry("LM"), std::invalid_argument);  // names are exact
  EXPECT_THROW((void)make_optimizer("", Bounds::unit_box(2), {}), std::invalid_argument);
}

TEST(Registry, RegistrationRefusesBuiltInPrefixAndIncompleteEntries) {
  AlgorithmEntry lm = algorithm_entry("lm");
  EXPECT_THROW(register_algorithm(lm), std::invalid_argument);
  AlgorithmEntry prefix = lm;
  prefix.name = "mine:";
  EXPECT_THROW(register_algorithm(prefix), std::invalid_argument);
  AlgorithmEntry no_factory = lm;
  no_factory.name = "lm-copy";
  no_factory.make = nullptr;
  EXPECT_THROW(register_algorithm(no_factory), std::invalid_argument);
  // Nothing was added, and "lm" is still the built-in one.
  EXPECT_NE(unknown_message("lm-copy"), "");
  EXPECT_TRUE(algorithm_traits("lm").needs_residuals);
}

// The interface traits say what the optimizer made by the same entry implements.
TEST(Registry, InterfaceTraitsMatchTheOptimizersMade) {
  for (const std::string& name : algorithm_names()) {
    SCOPED_TRACE(name);
    const AlgorithmTraits traits = algorithm_traits(name);
    const std::unique_ptr<Optimizer> optimizer = make_optimizer(name, Bounds::unit_box(3), {});
    EXPECT_EQ(traits.needs_residuals, dynamic_cast<ResidualConsumer*>(optimizer.get()) != nullptr);
    EXPECT_EQ(traits.needs_problem, dynamic_cast<ProblemConsumer*>(optimizer.get()) != nullptr);
    // A least-squares algorithm sees the residuals, through the problem or handed over.
    if (traits.least_squares) {
      EXPECT_TRUE(traits.needs_residuals || traits.needs_problem);
    }
  }
  EXPECT_TRUE(algorithm_traits("lm").least_squares);
  EXPECT_FALSE(algorithm_traits("dvpio").least_squares);
}

// stochastic: the seed changes the run (else two seeds give the same run).
TEST(Registry, StochasticTraitMatchesWhetherTheSeedChangesTheRun) {
  const ResidualSphere sphere(4);
  for (const std::string& name : algorithm_names()) {
    if (algorithm_traits(name).needs_problem) continue;  // runs only on its own problem
    SCOPED_TRACE(name);
    RunConfig one;
    one.seed = 1;
    one.max_iterations = 0;
    one.max_evaluations = 1;  // the first candidate: a population member or the first start
    RunConfig two = one;
    two.seed = 2;
    const Result a = optimize(name, sphere, one);
    const Result b = optimize(name, sphere, two);
    EXPECT_EQ(algorithm_traits(name).stochastic, !test::same(a.best_x, b.best_x));
  }
}

// parameter_info lists default_parameters with units; the distances in the box are exactly the
// parameters documented in normalised (problem) units.
TEST(Registry, ParameterInfoGivesTheDefaultsAndTheDistanceUnits) {
  std::vector<std::string> distances;
  for (const std::string& name : algorithm_names()) {
    SCOPED_TRACE(name);
    const ParameterInfoList info = parameter_info(name);
    ParameterList list;
    for (const ParameterInfo& p : info) {
      list.emplace_back(p.name, p.value);
      if (p.unit == ParameterUnit::kBoxDistance) distances.push_back(name + "." + p.name);
    }
    EXPECT_EQ(list, default_parameters(name));
  }
  EXPECT_EQ(distances, (std::vector<std::string>{
                           "dvpio.dist_threshold", "dvpio.d_initial", "dvpio.d_min", "dvpio.d_max",
                           "lm.fd_step", "bobyqa.initial_step", "bobyqa.xtol_abs",
                           "neldermead.initial_step", "neldermead.xtol_abs"}));
}

// The names written to results' "termination".
TEST(Termination, NamesRoundTrip) {
  test::expect_enum_table(kTerminationNames, {{Termination::kNone, "running"},
                                              {Termination::kIterations, "iterations"},
                                              {Termination::kEvaluations, "evaluations"},
                                              {Termination::kTarget, "target"}});
  EXPECT_EQ(to_string(Termination::kEvaluations), "evaluations");
}

}  // namespace
}  // namespace insid::opt
