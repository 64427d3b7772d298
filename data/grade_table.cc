#include "data/grade_table.h"

#include <array>
#include <stdexcept>
#include <string>

#include "model/sensor_errors.h"
#include "model/units.h"

namespace insid {
namespace {

// The figures of the top of grade_table.h. nav's biases are the catalogue's sigmas by
// construction (kSigmaGyroRadS, kSigmaAccelMps2): the nav grade searches in catalogue units.
constexpr const char* kTenSigma = "ten times the grade's one sigma (data/grade_table.h)";
constexpr std::array<GradeFigures, 3> kGrades = {{
    {"nav",
     kSigmaGyroRadS,
     kSigmaAccelMps2,
     1e-4,
     1e-4,
     {0.002, 0.001, 0.01, 0.02},
     10 * kSigmaGyroRadS,
     10 * kSigmaAccelMps2,
     1e-3,
     1e-3,
     kTenSigma},
    {"tactical",
     1.0 * kDegToRad / 3600.0,
     1e-3 * kStandardGravity_mps2,
     3e-4,
     3e-4,
     {0.05, 0.02, 0.02, 0.1},
     10.0 * kDegToRad / 3600.0,
     10e-3 * kStandardGravity_mps2,
     3e-3,
     3e-3,
     kTenSigma},
    {"mems",
     0.1 * kDegToRad,
     10e-3 * kStandardGravity_mps2,
     1e-3,
     1e-3,
     {0.2, 0.05, 0.03, 0.5},
     20.0 * kDegToRad,
     80e-3 * kStandardGravity_mps2,
     0.03,
     0.02,
     "the MPU-6000/6050 datasheet's initial tolerances (PS-MPU-6000A-00 rev. 3.4, sec. 6.1-6.2: "
     "zero-rate +-20 deg/s, zero-g +-80 mg, sensitivity +-3 %, cross-axis +-2 %)"},
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
