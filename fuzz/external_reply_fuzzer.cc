// libFuzzer target for one reply line of the external-optimizer protocol (optimizers/external.h,
// parse_external_reply: a reply nested 100000 arrays deep must be refused, not overflow the
// stack). The input is the
// line, read against a 3-D box. The reader must return points inside the box (or the client's
// reason to give up) or throw std::runtime_error; any other exception, a point outside the box,
// a crash or a sanitizer report is a finding.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string_view>

#include "optimizers/external.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  static const insid::opt::Bounds box = [] {
    insid::opt::Bounds b;
    b.lower = Eigen::Vector3d(-1.0, -2.0, 0.5);
    b.upper = Eigen::Vector3d(1.0, 3.0, 2.0);
    return b;
  }();
  try {
    const insid::opt::ExternalReply reply =
        insid::opt::parse_external_reply(line, box, "reply to ask 1 (line 1 of its output) ");
    if (!reply.error && reply.points.empty()) {
      std::fprintf(stderr, "finding: a reply with neither points nor error\n");
      std::abort();
    }
    for (const Eigen::VectorXd& x : reply.points)
      for (int j = 0; j < 3; ++j)
        if (!(std::isfinite(x[j]) && x[j] >= box.lower[j] && x[j] <= box.upper[j])) {
          std::fprintf(stderr, "finding: coordinate %d = %g accepted outside the box\n", j, x[j]);
          std::abort();
        }
  } catch (const std::runtime_error&) {
    // refused with a message: fine
  } catch (const std::exception& e) {
    std::fprintf(stderr, "finding: not a runtime_error: %s\n", e.what());
    std::abort();
  }
  return 0;
}
