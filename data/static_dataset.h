// Exact data of a stationary IMU: Earth-rate and gravity increments at a fixed position and
// attitude, with sensor errors applied, and GNSS at rest. Used by tests
// (test_support/test_support.h) and by the micro-benchmarks (bench/microbench.cc), so that no test
// helper is compiled into a shipped binary.
#pragma once

#include <cmath>

#include "data/dataset.h"
#include "model/earth.h"
#include "model/rotation.h"
#include "model/sensor_errors.h"

namespace insid {

/// A stationary IMU at (lat, lon, h) with attitude `att`, exact Earth-rate and gravity
/// increments at imu_rate_hz, `errors` applied; GNSS (zero velocity, true position) at
/// gnss_rate_hz. align_s of the duration is the alignment window.
inline Dataset make_static_dataset(const EarthModel& earth, double lat_rad, double lon_rad,
                                   double h_m, const EulerAngles& att, double duration_s,
                                   double align_s, const SensorErrors& errors = {},
                                   double imu_rate_hz = 100.0, double gnss_rate_hz = 1.0) {
  Dataset ds;
  ds.meta.imu_rate_hz = imu_rate_hz;
  ds.meta.gnss_rate_hz = gnss_rate_hz;
  ds.meta.earth = earth;
  ds.meta.align_s = align_s;
  ds.meta.initial.t_s = 0.0;
  ds.meta.initial.lat_rad = lat_rad;
  ds.meta.initial.lon_rad = lon_rad;
  ds.meta.initial.h_m = h_m;
  ds.meta.initial.attitude = att;
  const Eigen::Matrix3d C_n_b = C_b_n_from_euler(att).transpose();
  const Eigen::Vector3d omega_ib_b = C_n_b * earth.omega_ie_n(lat_rad);
  const Eigen::Vector3d f_ib_b = C_n_b * (-earth.gravity_n(lat_rad, h_m));
  const double dt = 1.0 / imu_rate_hz;
  const auto n_imu = static_cast<long>(std::llround(duration_s * imu_rate_hz));
  ds.imu.reserve(static_cast<std::size_t>(n_imu));
  for (long k = 1; k <= n_imu; ++k) {
    ImuSample s;
    s.t_s = static_cast<double>(k) * dt;
    s.dtheta_b_rad = omega_ib_b * dt;
    s.dv_b_mps = f_ib_b * dt;
    apply_imu_errors(errors, s.t_s, dt, s.dtheta_b_rad, s.dv_b_mps);
    ds.imu.push_back(s);
  }
  const auto n_gnss = static_cast<long>(std::llround(duration_s * gnss_rate_hz));
  for (long k = 0; k <= n_gnss; ++k) {
    GnssSample g;
    g.t_s = static_cast<double>(k) / gnss_rate_hz;
    g.lat_rad = lat_rad;
    g.lon_rad = lon_rad;
    g.h_m = h_m;
    ds.gnss.push_back(g);
  }
  return ds;
}

}  // namespace insid
