// Noise model of a dataset, for the discrepancy workflow (diagnose/README.md) and the
// uncertainty of an identification (identification/uncertainty.h):
//   * the noise levels (declared in meta.json "noise", or estimated from the data itself:
//     IMU random walks and GNSS noise from the static alignment window, where the truth is
//     constant, with a high-frequency fallback over the whole flight);
//   * noise replicas: the dataset's own IMU increments and GNSS solution with extra white noise
//     of those levels added. Run through the same pipeline at the same parameters, the
//     difference to the unperturbed run is one draw of the residuals' noise response
//     (linear regime: noise on top of noise has the same response as the data's own noise).
// Nothing here knows how the data were generated.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "data/dataset.h"

namespace insid {

struct NoiseEstimate {
  NoiseLevels levels;     ///< the levels used
  std::string source;     ///< "meta.json" | "estimated: ..." | "given"
  NoiseLevels estimated;  ///< always computed from the data (a consistency check)
  std::string estimate_method;
  nlohmann::json to_json() const;
};

/// Levels estimated from the data: robust (MAD) spread of first differences of the IMU
/// increments / GNSS solution inside the static alignment window (constant truth, so the
/// differences are pure noise); without an alignment window of at least 100 IMU samples,
/// second differences over the whole flight (smooth motion cancels to first order).
NoiseLevels estimate_noise_levels(const Dataset& dataset, std::string* method = nullptr);

/// The IMU's noise in flight: the robust (MAD) spread of second differences of the IMU
/// increments after the static alignment window (smooth motion cancels to first order; at a
/// drone's 50 Hz the motion's share is small beside the motors' vibration), as random walks
/// (arw_deg_rth, vrw_mps_rth; the GNSS fields are 0). The static window of a drone is taken
/// with the motors off and can be 50x quieter than the flight (the shared ArduPilot log: gyro
/// 0.01 vs 0.3-3 deg/s per sample). Falls back to the whole data when fewer than 100 rows follow
/// the window.
NoiseLevels estimate_flight_imu_noise(const Dataset& dataset);

/// Declared levels when meta.json has them, else the estimate.
NoiseEstimate noise_levels_for(const Dataset& dataset);

/// A copy of `dataset` with extra white noise of `levels`: per IMU axis and sample
/// N(0, arw^2 dt) on dtheta and N(0, vrw^2 dt) on dv; per GNSS epoch and ENU axis N(0, sv^2) on
/// the velocity and N(0, sp^2) on the position. Deterministic in `seed`.
Dataset noise_replica(const Dataset& dataset, const NoiseLevels& levels, std::uint64_t seed);

}  // namespace insid
