#include "core/grade_table.h"

#include <array>
#include <stdexcept>
#include <string>

#include "core/sensor_errors.h"
#include "core/units.h"

namespace insid {
namespace {

// The figures of the top of grade_table.h. nav's biases are the catalogue's sigmas by
// construction (kSigmaGyroRadS, kSigmaAccelMps2): the nav grade searches in catalogue units.
constexpr std::array<GradeFigures, 3> kGrades = {{
    {"nav", kSigmaGyroRadS, kSigmaAccelMps2, 1e-4, 1e-4, {0.002, 0.001, 0.01, 0.02}},
    {"tactical",
     1.0 * kDegToRad / 3600.0,
     1e-3 * kStandardGravity_mps2,
     3e-4,
     3e-4,
     {0.05, 0.02, 0.02, 0.1}},
    {"mems", 0.1 * kDegToRad, 10e-3 * kStandardGravity_mps2, 1e-3, 1e-3, {0.2, 0.05, 0.03, 0.5}},
}};

}  // namespace

std::span<const GradeFigures> grade_table() { return kGrades; }

const GradeFigures& grade_figures(std::string_view name) {
  for (const GradeFigures& g : kGrades)
    if (g.name == name) return g;
  throw std::invalid_argument("unknown sensor grade '" + std::string(name) +
                              "'; valid grades are: nav, tactical, mems");
}

}  // namespace insid
