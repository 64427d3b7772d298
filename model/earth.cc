#include "model/earth.h"

#include <cmath>
#include <sstream>

namespace insid {

double EarthModel::meridian_radius_m(double lat_rad) const {
  const double e2 = ellipsoid.e2();
  const double s = std::sin(lat_rad);
  const double w2 = 1.0 - e2 * s * s;
  return ellipsoid.a_m * (1.0 - e2) / (w2 * std::sqrt(w2));
}

double EarthModel::prime_vertical_radius_m(double lat_rad) const {
  const double s = std::sin(lat_rad);
  return ellipsoid.a_m / std::sqrt(1.0 - ellipsoid.e2() * s * s);
}

double EarthModel::normal_gravity_mps2(double lat_rad, double h_m) const {
  // docs/design.md sec. 3: g = g_eq (1 + 5.27094e-3 sin^2 + 2.32718e-5 sin^4) - 3.086e-6 h.
  const double s2 = std::sin(lat_rad) * std::sin(lat_rad);
  return g_eq_mps2 * (1.0 + 5.27094e-3 * s2 + 2.32718e-5 * s2 * s2) - 3.086e-6 * h_m;
}

Eigen::Vector3d EarthModel::gravity_n(double lat_rad, double h_m) const {
  return {0.0, 0.0, -normal_gravity_mps2(lat_rad, h_m)};
}

Eigen::Vector3d EarthModel::omega_ie_n(double lat_rad) const {
  return {0.0, omega_ie_rad_s * std::cos(lat_rad), omega_ie_rad_s * std::sin(lat_rad)};
}

Eigen::Vector3d EarthModel::omega_en_n(double lat_rad, double h_m,
                                       const Eigen::Vector3d& v_eb_n) const {
  const double rm_h = meridian_radius_m(lat_rad) + h_m;
  const double rn_h = prime_vertical_radius_m(lat_rad) + h_m;
  return {-v_eb_n.y() / rm_h, v_eb_n.x() / rn_h, v_eb_n.x() * std::tan(lat_rad) / rn_h};
}

std::string EarthModel::validate() const {
  std::ostringstream err;
  if (!(ellipsoid.a_m > 6.0e6 && ellipsoid.a_m < 7.0e6))
    err << "earth.a_m must be in (6e6, 7e6) m, got " << ellipsoid.a_m;
  else if (!(ellipsoid.f >= 0.0 && ellipsoid.f < 0.01))
    err << "earth.f must be in [0, 0.01), got " << ellipsoid.f;
  else if (!(omega_ie_rad_s > 0.0 && omega_ie_rad_s < 1.0e-3))
    err << "earth.omega_ie_rad_s must be in (0, 1e-3) rad/s, got " << omega_ie_rad_s;
  else if (!(g_eq_mps2 > 9.0 && g_eq_mps2 < 10.5))
    err << "earth.g_eq_mps2 must be in (9, 10.5) m/s^2, got " << g_eq_mps2;
  return err.str();
}

EarthModel EarthModel::paper(double lat_rad, double h_m, double g0_mps2) {
  EarthModel earth;
  earth.ellipsoid = Ellipsoid::krasovsky1940();
  earth.omega_ie_rad_s = 7.292115147e-5;
  const double s2 = std::sin(lat_rad) * std::sin(lat_rad);
  earth.g_eq_mps2 = (g0_mps2 + 3.086e-6 * h_m) / (1.0 + 5.27094e-3 * s2 + 2.32718e-5 * s2 * s2);
  return earth;
}

}  // namespace insid
