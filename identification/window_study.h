// The windowed fitness's trade-off (nav/fitness.h "Windowed fitness"): on a
// simulated flight, for a window length W, the Eq. 15 optimum of the paper's four biases and
// its Gauss-Newton standard deviations. Used by `insid-window-study` (results/window/) and by
// windowed_fitness_test.cc.
//
// Set-up (stated in results/window/README.md): the `rich` preset shortened to `flight_s`, the
// noise of the grade (scenarios/noise.cc), the biases switched on after the alignment window and
// the alignment done once on the data as recorded (`fixed`): the initial attitude is then the
// true one up to the window's noise. This stands in for a given initial attitude (MEMS gyro
// biases of 0.1-1 deg/s dwarf Earth rate, so gyrocompassing on MEMS data is meaningless; the
// initial-attitude modes of nav/alignment.h are not used here). That is SetUp::kFixedGiven, the
// set-up of the first tables; SetUp::kGradeAlignment is the alignment each grade uses (below).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "base/enum_table.h"
#include "data/dataset.h"
#include "identification/ins_problem.h"
#include "nav/fitness.h"

namespace insid::window_study {

/// A grade's search unit (sigma) and injected biases, in the paper's pattern [-2, 1.5, 2, -1.5]
/// sigma on accel_bias_x, accel_bias_y, gyro_bias_x, gyro_bias_y.
struct Grade {
  std::string name;               ///< "mems" | "nav" (scenarios::noise_grade)
  double sigma_gyro_rad_s = 0.0;  ///< one sigma of a gyro bias (rad/s)
  double sigma_accel_mps2 = 0.0;  ///< one sigma of an accelerometer bias (m/s^2)
};
/// "mems": sigma 0.1 deg/s and 10 mg (injected 0.2 / -0.15 deg/s, -20 / 15 mg); "nav": the
/// paper's sigmas (0.01 deg/h, 0.0005 m/s^2). Throws std::invalid_argument otherwise.
Grade grade(const std::string& name);

/// How the study's flights start (results/window/README.md).
enum class SetUp {
  /// Biases on after the 600 s static window, the attitude aligned once on the recorded data
  /// (`fixed`, gyrocompassing accepted on MEMS data): a stand-in for a given attitude.
  kFixedGiven,
  /// The alignment each grade uses, biases on from t = 0, per-candidate alignment. nav: 600 s
  /// static, gyrocompass, the paper's four biases. mems: 30 s static, level+heading from the
  /// GNSS course, the four and gyro_bias_z (identification/grade.h: MEMS estimates it; the
  /// heading it builds is what level+heading cannot see), injected 2 sigma (0.2 deg/s).
  kGradeAlignment,
};
inline constexpr EnumTable<SetUp, 2> kSetUpNames{
    "window study: set-up",
    {{{SetUp::kFixedGiven, "fixed-given"}, {SetUp::kGradeAlignment, "grade"}}}};
/// "fixed-given" | "grade"; throws std::invalid_argument naming the value otherwise.
inline SetUp set_up_from_string(const std::string& text) { return kSetUpNames.value(text); }

/// The injected biases in sigma units, in the mapping's order.
Eigen::VectorXd truth_sigma(const Grade& g = grade("nav"), SetUp set_up = SetUp::kFixedGiven);
/// The estimated parameters with the grade's sigmas and the [-4, 4] sigma box: the paper's four
/// (accel_bias_x|y, gyro_bias_x|y), and gyro_bias_z for mems with kGradeAlignment.
ParameterMapping mapping(const Grade& g, SetUp set_up = SetUp::kFixedGiven);

/// The simulated flight (see the top of this file and SetUp): rich preset, flight_s after the
/// static window, the grade's noise with `seed`.
std::shared_ptr<const Dataset> flight(const Grade& g, double flight_s, std::uint64_t seed,
                                      SetUp set_up = SetUp::kFixedGiven);

struct WindowFit {
  double window_s = 0.0;
  std::size_t windows = 0;
  Eigen::VectorXd optimum_sigma;      ///< local Eq. 15 fit started at the truth (sigma units)
  Eigen::VectorXd from_centre_sigma;  ///< local Eq. 15 fit started at the box centre
  Eigen::VectorXd gn_sd_sigma;        ///< sqrt diag of s^2 (J^T J)^-1 at the optimum, s^2 =
                                      ///< sum of squares / (m - n) (white-residual assumption)
  double fitness_optimum = 0.0;       ///< Eq. 15 at optimum_sigma
  double fitness_from_centre = 0.0;   ///< Eq. 15 at from_centre_sigma
  Eigen::VectorXd pso_sigma;          ///< PSO at the paper's budget (10 x 40, Table 4), best point
};
/// The fits for one window length (W = 0: one run) on the given flight; `pso_seed` seeds the
/// PSO run.
WindowFit fit_window(const std::shared_ptr<const Dataset>& data, const Grade& g, double window_s,
                     int threads = 1, std::uint64_t pso_seed = 1,
                     SetUp set_up = SetUp::kFixedGiven);

}  // namespace insid::window_study
