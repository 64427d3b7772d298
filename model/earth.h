// Earth model: reference ellipsoid, curvature radii, normal gravity, Earth rate.
// Conventions (docs/design.md sec. 3): SI units and radians; n frame = local level ENU.
#pragma once

#include <string>

#include <Eigen/Core>

#include "model/units.h"  // kStandardGravity_mps2 (included by many through this header)

namespace insid {

/// Reference ellipsoid given by its semi-major axis and flattening.
struct Ellipsoid {
  double a_m = 6378137.0;          ///< semi-major axis (m)
  double f = 1.0 / 298.257223563;  ///< flattening (1)

  double e2() const { return f * (2.0 - f); }  ///< first eccentricity squared

  static Ellipsoid wgs84() { return {6378137.0, 1.0 / 298.257223563}; }
  static Ellipsoid krasovsky1940() { return {6378245.0, 1.0 / 298.3}; }
};

/// Everything the mechanization needs to know about the Earth.
struct EarthModel {
  Ellipsoid ellipsoid = Ellipsoid::wgs84();
  double omega_ie_rad_s = 7.292115e-5;  ///< Earth rotation rate (rad/s)
  double g_eq_mps2 = 9.7803267714;      ///< normal gravity at the equator (m/s^2)

  /// Meridian radius of curvature R_M (m).
  double meridian_radius_m(double lat_rad) const;
  /// Prime-vertical radius of curvature R_N (m).
  double prime_vertical_radius_m(double lat_rad) const;
  /// Normal gravity magnitude (docs/design.md sec. 3), along the ellipsoid normal (m/s^2).
  double normal_gravity_mps2(double lat_rad, double h_m) const;
  /// Gravity vector g_n in ENU: (0, 0, -g).
  Eigen::Vector3d gravity_n(double lat_rad, double h_m) const;
  /// Earth rate in the n frame: omega_ie_n = (0, W cos(lat), W sin(lat)).
  Eigen::Vector3d omega_ie_n(double lat_rad) const;
  /// Transport rate omega_en_n for ground velocity v_eb_n (ENU).
  Eigen::Vector3d omega_en_n(double lat_rad, double h_m, const Eigen::Vector3d& v_eb_n) const;

  /// Empty when valid, else a message naming the bad field and value.
  std::string validate() const;

  /// The paper's Table 3 Earth (docs/design.md sec. 2): Krasovsky-1940, Earth rate 7.292115147e-5,
  /// g_eq chosen so that gravity at (lat_rad, h_m) equals g0_mps2.
  static EarthModel paper(double lat_rad, double h_m, double g0_mps2 = 9.801);
  static EarthModel wgs84() { return {}; }
};

}  // namespace insid
