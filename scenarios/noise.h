// Noise grades and a portable Gaussian random source.
//
// Every random draw comes from std::mt19937_64 (its output sequence is fixed by the C++
// standard) turned into normals by our own Box-Muller transform, so the same seed gives the
// same bytes on every platform (std::normal_distribution is implementation-defined).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <string_view>

#include "data/dataset.h"

namespace insid::scenarios {

/// splitmix64: derives independent stream seeds from one user seed.
std::uint64_t splitmix64(std::uint64_t x);

class GaussianRng {
 public:
  explicit GaussianRng(std::uint64_t seed) : engine_(seed) {}
  /// Uniform in [0, 1), 53 random bits.
  double uniform();
  /// Standard normal (Box-Muller; the second value of each pair is kept for the next call).
  double normal();

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// Noise levels of one dataset. White noise on the IMU increments (random walks), white noise
/// on the GNSS solution, optional first-order Gauss-Markov bias instability on every IMU axis.
struct NoiseSpec {
  std::string grade = "none";        ///< name of the grade the levels started from
  double arw_deg_rth = 0.0;          ///< angle random walk (deg/sqrt(h))
  double vrw_mps_rth = 0.0;          ///< velocity random walk (m/s/sqrt(h))
  double gnss_vel_sigma_mps = 0.0;   ///< per ENU axis (m/s)
  double gnss_pos_sigma_m = 0.0;     ///< per ENU axis (m)
  double gm_gyro_sigma_deg_h = 0.0;  ///< Gauss-Markov gyro bias steady-state sigma (deg/h)
  double gm_accel_sigma_mps2 = 0.0;  ///< Gauss-Markov accel bias steady-state sigma (m/s^2)
  double gm_tau_s = 3600.0;          ///< Gauss-Markov correlation time (s)

  /// Empty when valid, else a message naming the bad field and value.
  std::string validate() const;
  bool is_zero() const;
  /// The four levels recorded in meta.json.
  NoiseLevels levels() const;
};

/// Grades: "nav" (optical-gyro INS), "mems", "paper" (near noise-free, docs/design.md sec. 10),
/// "none". Throws std::invalid_argument listing the valid names otherwise.
NoiseSpec noise_grade(std::string_view name);

}  // namespace insid::scenarios
