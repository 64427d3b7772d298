// Test errors: the message of what a piece of code throws, for checks on refusals.
#pragma once

#include <functional>
#include <string>

namespace insid::test {

/// The what() of the std::exception that `f` throws; "" when it returns.
std::string error_of(const std::function<void()>& f);

}  // namespace insid::test
