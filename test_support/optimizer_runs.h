// Optimizer runs compared bit for bit, for the tests of every optimizer and the campaigns.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "optimizers/optimizer.h"

namespace insid::test {

/// Same size and, when not empty, the same values to the bit.
bool same(const Eigen::VectorXd& a, const Eigen::VectorXd& b);
bool same(const std::vector<Eigen::VectorXd>& a, const std::vector<Eigen::VectorXd>& b);

/// Bit-for-bit equality of everything in two results except the wall time (GoogleTest
/// expectations, one failure for each field that differs).
void expect_same_run(const opt::Result& a, const opt::Result& b);

}  // namespace insid::test
