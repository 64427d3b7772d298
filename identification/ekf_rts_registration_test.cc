// "ekf-rts" is in the optimizer registry of every program that links insid_identification,
// without a call of its own: this test's program refers to nothing of ekf_rts.cc, so only the
// library's link interface (identification/CMakeLists.txt) brings its registrar in.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "optimizers/registry.h"

namespace insid {
namespace {

TEST(EkfRtsRegistration, IsInTheRegistryWithoutACall) {
  const std::vector<std::string> names = opt::algorithm_names();
  ASSERT_NE(std::find(names.begin(), names.end(), "ekf-rts"), names.end());
  // Listed after the built-in algorithms.
  EXPECT_EQ(names.back(), "ekf-rts");
  const opt::AlgorithmTraits traits = opt::algorithm_traits("ekf-rts");
  EXPECT_EQ(traits.family, opt::AlgorithmTraits::Family::kProblemSpecific);
  EXPECT_TRUE(traits.least_squares);
  EXPECT_TRUE(traits.needs_problem);
  EXPECT_FALSE(traits.needs_residuals);
  EXPECT_FALSE(traits.stochastic);
  EXPECT_FALSE(opt::default_parameters("ekf-rts").empty());
}

}  // namespace
}  // namespace insid
