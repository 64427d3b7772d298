#include "test_support/errors.h"

#include <exception>

namespace insid::test {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace insid::test
